//! `report.html`: one self-contained page a browser opens offline. It holds what `table.md`
//! says (rendered from that very Markdown, so the two cannot disagree), every flagged or failed
//! pair, the figures as inline SVG, the reference's quality, the configuration and provenance,
//! and the (non-reproducible) timings. Nothing outside the file is referenced: no stylesheet,
//! script, font or image is fetched; its tables sort on a click (a few lines of inline script).
//!
//! A command adds its own results to the run's page ([`Section`]s: `compare.md`, `sweep.md`,
//! `basin.md` and their figures) and writes it once with [`write()`].

use std::fmt::Write as _;

use datasets::Dataset;
use pulldown_cmark::{Event, HeadingLevel, Options, Parser, Tag, TagEnd};
use serde_json::Value;

use crate::error::EvalError;
use crate::measure::report::RunReport;
use crate::render::figures;
use crate::render::markdown::table_md;
use crate::render::outdir::OutputDir;
use crate::run::status::StatusKind;

/// One part of the page beyond a run's: a title, Markdown, and figures as `(stem, svg)`.
pub struct Section {
    /// Its heading.
    pub title: String,
    /// Its text (rendered like `table.md`).
    pub markdown: String,
    /// Its figures.
    pub svgs: Vec<(String, String)>,
}

/// Writes `report.html` into `out`: the run `report` of `ds` when there is one (its figures
/// when `plots`), then `sections`.
pub fn write(
    out: &mut OutputDir,
    ds: &Dataset,
    report: Option<&RunReport>,
    plots: bool,
    sections: &[Section],
) -> Result<(), EvalError> {
    let run_figures = match report {
        Some(r) if plots => figures::run::svgs(ds, r)?,
        _ => Vec::new(),
    };
    out.write(
        "report.html",
        page(ds, report, plots, &run_figures, sections).as_bytes(),
    )
}

/// The whole page.
pub fn page(
    ds: &Dataset,
    report: Option<&RunReport>,
    plots: bool,
    run_figures: &[(String, String)],
    sections: &[Section],
) -> String {
    let title = format!("icp-eval: {}", ds.provenance.name);
    let mut body = String::new();
    let mut toc = Vec::new();
    if let Some(r) = report {
        let mut part = |id: &str, heading: &str, html: String| {
            toc.push((id.to_owned(), heading.to_owned()));
            let _ = write!(
                body,
                "<section id=\"{id}\"><h2>{}</h2>\n{html}</section>\n",
                esc(heading)
            );
        };
        part("results", "Results", markdown_html(&table_md(r)));
        part("flags", "Flags and failures", flags_html(r));
        let figures = if plots {
            figures_html("fig", run_figures)
        } else {
            "<p>The figures were skipped (<code>--no-plots</code>).</p>\n".to_owned()
        };
        part("figures", "Figures", figures);
        part("reference", "The reference", reference_html(r));
        part(
            "configuration",
            "Configuration and provenance",
            provenance_html(r),
        );
        part("timing", "Timing (not reproducible)", timing_html(r));
    }
    for (k, s) in sections.iter().enumerate() {
        let id = format!("section-{k}");
        toc.push((id.clone(), s.title.clone()));
        let _ = write!(
            body,
            "<section id=\"{id}\"><h2>{}</h2>\n{}{}</section>\n",
            esc(&s.title),
            markdown_html(&s.markdown),
            figures_html(&id, &s.svgs)
        );
    }
    let mut nav = String::from("<nav><ul>");
    for (id, heading) in &toc {
        let _ = write!(nav, "<li><a href=\"#{id}\">{}</a></li>", esc(heading));
    }
    nav.push_str("</ul></nav>\n");
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>{t}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<header><h1>{t}</h1>\n\
         <p>{desc}</p></header>\n{nav}<main>\n{body}</main>\n<script>{SORT_SCRIPT}</script>\n\
         </body>\n</html>\n",
        t = esc(&title),
        desc = esc(&ds.provenance.description),
    )
}

/// `text` escaped for HTML text and attribute values.
fn esc(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// Markdown (GFM tables) as HTML, its headings one level down (the page's sections are h2)
/// and its tables sortable.
fn markdown_html(md: &str) -> String {
    let events = Parser::new_ext(md, Options::ENABLE_TABLES).map(|e| match e {
        Event::Start(Tag::Heading {
            level,
            id,
            classes,
            attrs,
        }) => Event::Start(Tag::Heading {
            level: deeper(level),
            id,
            classes,
            attrs,
        }),
        Event::End(TagEnd::Heading(level)) => Event::End(TagEnd::Heading(deeper(level))),
        // A raw HTML block in our Markdown would be a bug: shown as text, never run.
        Event::Html(h) | Event::InlineHtml(h) => Event::Text(h),
        e => e,
    });
    let mut html = String::new();
    pulldown_cmark::html::push_html(&mut html, events);
    html.replace("<table>", "<table class=\"sortable\">")
}

fn deeper(level: HeadingLevel) -> HeadingLevel {
    match level {
        HeadingLevel::H1 => HeadingLevel::H3,
        HeadingLevel::H2 => HeadingLevel::H4,
        HeadingLevel::H3 => HeadingLevel::H5,
        _ => HeadingLevel::H6,
    }
}

/// Each figure in a `<figure>` of its own, its SVG inline, `id` `<prefix>-<stem>`.
fn figures_html(prefix: &str, svgs: &[(String, String)]) -> String {
    let mut out = String::new();
    for (stem, svg) in svgs {
        // The SVG text of plotters starts with an XML declaration in some versions: not
        // allowed inside HTML, so the page keeps the <svg> element only.
        let svg = svg.find("<svg").map_or(svg.as_str(), |i| &svg[i..]);
        let _ = writeln!(
            out,
            "<figure id=\"{prefix}-{}\" data-figure=\"{}\">{svg}<figcaption>{}</figcaption></figure>",
            esc(stem),
            esc(stem),
            esc(stem)
        );
    }
    out
}

/// A sortable table of `header` and `rows` (cells escaped here).
fn table(header: &[&str], rows: impl IntoIterator<Item = Vec<String>>) -> String {
    let mut out = String::from("<table class=\"sortable\"><thead><tr>");
    for h in header {
        let _ = write!(out, "<th>{}</th>", esc(h));
    }
    out.push_str("</tr></thead><tbody>\n");
    for row in rows {
        out.push_str("<tr>");
        for cell in row {
            let _ = write!(out, "<td>{}</td>", esc(&cell));
        }
        out.push_str("</tr>\n");
    }
    out.push_str("</tbody></table>\n");
    out
}

/// Every record whose status is not `ok`: the pairs a variant failed or flagged, and why.
fn flags_html(report: &RunReport) -> String {
    let rows: Vec<Vec<String>> = report
        .pairs
        .iter()
        .filter(|r| r.status != StatusKind::Ok)
        .map(|r| {
            vec![
                r.variant.clone(),
                r.pair.to_string(),
                format!("{} → {}", r.source, r.reference),
                serde_json::to_value(r.status)
                    .ok()
                    .and_then(|v| v.as_str().map(str::to_owned))
                    .unwrap_or_default(),
                r.status_reason.clone(),
            ]
        })
        .collect();
    if rows.is_empty() {
        return "<p>No pair was flagged or failed.</p>\n".to_owned();
    }
    format!(
        "<p>{} records of {} are not <code>ok</code> (a failure of their variant).</p>\n{}",
        rows.len(),
        report.pairs.len(),
        table(&["variant", "pair", "scans", "status", "why"], rows)
    )
}

/// `value` flattened to `(dotted key, value)` rows; arrays of scalars joined, of objects
/// indexed.
fn flatten(prefix: &str, value: &Value, out: &mut Vec<Vec<String>>) {
    match value {
        Value::Object(map) => {
            for (k, v) in map {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&key, v, out);
            }
        }
        Value::Array(items) if items.iter().any(|v| v.is_object() || v.is_array()) => {
            for (i, v) in items.iter().enumerate() {
                flatten(&format!("{prefix}[{i}]"), v, out);
            }
        }
        Value::Array(items) => out.push(vec![
            prefix.to_owned(),
            items.iter().map(scalar).collect::<Vec<_>>().join(", "),
        ]),
        v => out.push(vec![prefix.to_owned(), scalar(v)]),
    }
}

fn scalar(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        Value::Null => "–".to_owned(),
        v => v.to_string(),
    }
}

/// A key–value table of `value` (serialised as in `summary.json`).
fn key_values(value: &impl serde::Serialize) -> String {
    let mut rows = Vec::new();
    if let Ok(v) = serde_json::to_value(value) {
        flatten("", &v, &mut rows);
    }
    table(&["field", "value"], rows)
}

fn reference_html(report: &RunReport) -> String {
    let mut out = String::from(
        "<p>The reference is not truth: what it is, how it was aligned, and the steps \
         left out as implausible (<code>summary.json</code> <code>reference</code>).</p>\n",
    );
    out.push_str(&key_values(&report.reference));
    let noise: Vec<(String, Value)> = report
        .variants
        .iter()
        .filter_map(|v| {
            let c = serde_json::to_value(v.consistency.as_ref()?).ok()?;
            let noise = c.get("reference_noise")?.clone();
            (!noise.is_null()).then(|| (v.name.clone(), noise))
        })
        .take(1)
        .collect();
    for (_, n) in noise {
        out.push_str("<h3>The reference's own noise</h3>\n");
        out.push_str(&key_values(&n));
    }
    out
}

fn provenance_html(report: &RunReport) -> String {
    let mut out = format!(
        "<p>Made by {} (summary.json schema {}).</p>\n<h3>Data</h3>\n",
        esc(&report.tool),
        report.schema_version
    );
    out.push_str(&table(
        &["file", "SHA-256", "matches the pinned sum"],
        report.dataset.files.iter().map(|f| {
            vec![
                f.path.display().to_string(),
                f.sha256.clone(),
                f.matches_pinned.map_or("–".to_owned(), |m| {
                    if m { "yes" } else { "NO" }.to_owned()
                }),
            ]
        }),
    ));
    out.push_str(&key_values(&report.dataset));
    out.push_str("<h3>Configuration</h3>\n");
    out.push_str(&key_values(&report.config));
    if let Ok(json) = serde_json::to_string_pretty(&report.config) {
        let _ = writeln!(
            out,
            "<details><summary><code>config.json</code></summary><pre>{}</pre></details>",
            esc(&json)
        );
    }
    out
}

fn timing_html(report: &RunReport) -> String {
    let us = |t: Option<crate::measure::report::Timing>,
              f: fn(&crate::measure::report::Timing) -> f64| {
        t.map_or("–".to_owned(), |t| format!("{:.0}", f(&t)))
    };
    let mut rows: Vec<Vec<String>> = report
        .variants
        .iter()
        .map(|v| {
            vec![
                v.name.clone(),
                us(v.timing, |t| t.median_us),
                us(v.timing, |t| t.p95_us),
            ]
        })
        .collect();
    rows.push(vec![
        "surface estimates, per scan".to_owned(),
        us(report.preparation, |t| t.median_us),
        us(report.preparation, |t| t.p95_us),
    ]);
    if let Some(g) = &report.global_search {
        rows.push(vec![
            "global search, per pair".to_owned(),
            us(g.timing, |t| t.median_us),
            us(g.timing, |t| t.p95_us),
        ]);
    }
    format!(
        "<p>Wall time on the machine that ran it, per registration unless said.</p>\n{}",
        table(&["what", "median µs", "p95 µs"], rows)
    )
}

/// The page's look: readable tables, figures scaled to the page.
const STYLE: &str = "body{font-family:sans-serif;margin:0 auto;max-width:1200px;padding:0 1em;\
color:#222}nav ul{display:flex;flex-wrap:wrap;gap:1em;list-style:none;padding:0}\
table{border-collapse:collapse;margin:.5em 0;font-size:.9em}th,td{border:1px solid #ccc;\
padding:.2em .5em;text-align:right}th{background:#eee;cursor:pointer;user-select:none}\
td:first-child,th:first-child{text-align:left}th.asc::after{content:' ▲'}\
th.desc::after{content:' ▼'}figure{margin:1em 0}figure svg{max-width:100%;height:auto}\
pre{background:#f6f6f6;padding:.5em;overflow:auto}code{background:#f3f3f3}";

/// Sorts a table by the clicked column (numerically where every cell reads as a number);
/// marks the page when it has run, so a browser check can tell the script ran.
const SORT_SCRIPT: &str = "document.querySelectorAll('table.sortable').forEach(t=>{\
const hs=[...t.querySelectorAll('thead th')];hs.forEach((h,i)=>h.addEventListener('click',()=>{\
const b=t.tBodies[0];const rs=[...b.rows];const up=!h.classList.contains('asc');\
hs.forEach(x=>x.classList.remove('asc','desc'));h.classList.add(up?'asc':'desc');\
const v=r=>(r.cells[i]||{}).textContent||'';const num=rs.every(r=>v(r)===''||v(r)==='–'||\
!isNaN(parseFloat(v(r))));rs.sort((a,c)=>{const x=v(a),y=v(c);const d=num?\
(parseFloat(x)||0)-(parseFloat(y)||0):x.localeCompare(y);return up?d:-d});\
rs.forEach(r=>b.appendChild(r))}))});document.body.dataset.sortReady=\
document.querySelectorAll('table.sortable').length;";
