//! `report.html`, read back by an HTML parser (html5ever, through `scraper`): in every output
//! directory of `run`, `compare --sweep`, `basin` and `merge`, one self-contained page holding
//! every figure the run drew (as inline SVG), a row for every variant in its tables, the
//! flagged pairs, the configuration and provenance, and nothing that points outside the file.
//! (`scripts/check-html.sh` opens the same pages in a real browser.)

mod common;

use std::collections::BTreeSet;
use std::path::Path;

use common::{icp_eval_ok, scratch_dir};
use scraper::{Html, Selector};

fn select(html: &Html, css: &str) -> Vec<String> {
    let sel = Selector::parse(css).expect("a valid selector");
    html.select(&sel)
        .map(|e| e.text().collect::<String>())
        .collect()
}

/// The parsed `report.html` of `dir`, checked to be self-contained: no element loads or links
/// anything outside the page (only `#fragment` links), no stylesheet link, no external script.
fn page(dir: &Path) -> Html {
    let text = std::fs::read_to_string(dir.join("report.html")).expect("report.html written");
    let html = Html::parse_document(&text);
    let any = Selector::parse("*").unwrap();
    for e in html.select(&any) {
        let el = e.value();
        for (name, value) in el.attrs() {
            let local = name.rsplit(':').next().unwrap_or(name);
            assert!(
                local != "src",
                "<{}> loads {value} from outside the page",
                el.name()
            );
            if local == "href" {
                assert!(
                    value.starts_with('#'),
                    "<{}> links to {value} outside the page",
                    el.name()
                );
            }
        }
        assert_ne!(el.name(), "link", "a <link> element: {el:?}");
        assert_ne!(el.name(), "iframe");
    }
    assert!(!text.contains("url(http"), "a style fetches a URL");
    assert!(!text.contains("@import"), "a style imports a sheet");
    assert!(
        !select(&html, "script").is_empty(),
        "the sort script is inline"
    );
    html
}

/// The figure stems of `dir`: every `.svg` file the command wrote.
fn svg_files(dir: &Path) -> BTreeSet<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| {
            let p = e.unwrap().path();
            (p.extension()? == "svg").then(|| p.file_stem().unwrap().to_string_lossy().into())
        })
        .collect()
}

/// Every figure file of `dir` is in its page as an inline `<svg>` inside its `<figure>`.
fn every_figure_inline(html: &Html, dir: &Path) {
    let sel = Selector::parse("figure[data-figure]").unwrap();
    let svg = Selector::parse("svg").unwrap();
    let mut inline = BTreeSet::new();
    for f in html.select(&sel) {
        assert!(
            f.select(&svg).next().is_some(),
            "figure {:?} has no inline <svg>",
            f.value().attr("data-figure")
        );
        inline.insert(f.value().attr("data-figure").unwrap().to_owned());
    }
    let files = svg_files(dir);
    assert!(!files.is_empty(), "no figure written in {}", dir.display());
    assert_eq!(inline, files, "figures in report.html vs .svg files");
}

/// Every name of `variants` starts a row of the run's Table 1 (all pairs) and of its failure
/// table.
fn every_variant_has_rows(html: &Html, variants: &[&str]) {
    let first_cells = select(html, "#results table tbody tr td:first-child");
    for v in variants {
        let rows = first_cells.iter().filter(|c| c.as_str() == *v).count();
        assert!(
            rows >= 2,
            "{v} starts {rows} rows of report.html's tables; expected Table 1 and the failures"
        );
    }
}

const VARIANTS: [&str; 4] = ["K_ICP", "HD_ICP", "PL_ICP", "HD_GICP"];

#[test]
fn a_run_page_holds_its_tables_figures_flags_and_provenance() {
    let dir = scratch_dir("html-run");
    let out = dir.join("run");
    icp_eval_ok(&[
        "run",
        "--dataset",
        "synthetic",
        "--scans",
        "30",
        "--variants",
        &VARIANTS.join(","),
        "--out",
        out.to_str().unwrap(),
    ]);
    let html = page(&out);
    every_figure_inline(&html, &out);
    every_variant_has_rows(&html, &VARIANTS);
    for id in ["results", "flags", "figures", "reference", "configuration"] {
        assert_eq!(select(&html, &format!("section#{id}")).len(), 1, "{id}");
    }
    // The provenance: the tool's version and the configuration of every variant.
    let provenance = select(&html, "#configuration").concat();
    assert!(provenance.contains("icp-eval"), "tool version");
    for v in VARIANTS {
        assert!(provenance.contains(v), "{v} in the configuration");
    }
    assert!(!select(&html, "table.sortable").is_empty());
    // What table.md says is on the page: its every table heading.
    let md = std::fs::read_to_string(out.join("table.md")).unwrap();
    let headings = select(&html, "#results h4").concat();
    for h in md.lines().filter_map(|l| l.strip_prefix("## ")) {
        let plain = h.replace('`', "");
        assert!(headings.contains(&plain), "table.md's {h:?} missing");
    }
}

/// A run whose detector of moving returns left some out draws the scan that lost the most,
/// titled with the count `pairs.csv` gives for it.
#[test]
fn the_scan_that_lost_the_most_returns_is_drawn() {
    let dir = scratch_dir("html-left-out");
    let out = dir.join("run");
    icp_eval_ok(&[
        "run",
        "--dataset",
        "synthetic:rough",
        "--scans",
        "200",
        "--variants",
        "PL_ICP",
        "--reference-checks",
        "off",
        "--out",
        out.to_str().unwrap(),
    ]);
    let mut most: Option<(usize, usize)> = None;
    let mut rows = csv::Reader::from_path(out.join("pairs.csv")).unwrap();
    let header = rows.headers().unwrap().clone();
    let column = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (source, left_out) = (column("source"), column("left_out_src"));
    for row in rows.records() {
        let row = row.unwrap();
        let n: usize = row[left_out].parse().unwrap();
        if n > most.map_or(0, |(_, m)| m) {
            most = Some((row[source].parse().unwrap(), n));
        }
    }
    let (scan, n) = most.expect("the boats' returns were left out");
    let html = page(&out);
    every_figure_inline(&html, &out);
    let figure = select(&html, "figure[data-figure=left_out]").concat();
    assert!(
        figure.contains(&format!("scan {scan} by PL_ICP: {n} of ")),
        "scan {scan} with {n} left out not drawn: {figure:.300}"
    );
}

#[test]
fn without_figures_the_page_says_so() {
    let dir = scratch_dir("html-no-plots");
    let out = dir.join("run");
    icp_eval_ok(&[
        "run",
        "--dataset",
        "synthetic",
        "--scans",
        "12",
        "--variants",
        "HD_ICP",
        "--no-plots",
        "--out",
        out.to_str().unwrap(),
    ]);
    let html = page(&out);
    assert!(select(&html, "svg").is_empty());
    assert!(select(&html, "#figures").concat().contains("--no-plots"));
}

#[test]
fn compare_basin_and_merge_pages_add_their_results() {
    let dir = scratch_dir("html-studies");
    let cmp = dir.join("compare");
    let args = [
        "compare",
        "--dataset",
        "synthetic",
        "--scans",
        "24",
        "--variants",
        "K_ICP,HD_ICP",
        "--sweep",
        "sigma_alpha_deg=0.25,1",
    ];
    let mut whole = args.to_vec();
    whole.extend(["--out", cmp.to_str().unwrap()]);
    icp_eval_ok(&whole);
    let html = page(&cmp);
    every_figure_inline(&html, &cmp);
    every_variant_has_rows(&html, &["K_ICP", "HD_ICP"]);
    let titles = select(&html, "section > h2").concat();
    assert!(titles.contains("Paired comparison") && titles.contains("Parameter sweep"));

    let basin = dir.join("basin");
    icp_eval_ok(&[
        "basin",
        "--dataset",
        "synthetic",
        "--scans",
        "8",
        "--variants",
        "HD_ICP,PL_ICP",
        "--perturbations",
        "2",
        "--out",
        basin.to_str().unwrap(),
    ]);
    let html = page(&basin);
    every_figure_inline(&html, &basin);
    let text = select(&html, "table tbody tr td:first-child");
    for v in ["HD_ICP", "PL_ICP"] {
        assert!(text.iter().any(|c| c == v), "{v} in basin's tables");
    }

    // A sharded compare, merged: the same page sections as the single run.
    let mut parts = Vec::new();
    for k in 0..2 {
        let part = dir.join(format!("part-{k}"));
        let mut sharded = args.to_vec();
        let shard = format!("{k}/2");
        sharded.extend(["--shard", &shard, "--out", part.to_str().unwrap()]);
        icp_eval_ok(&sharded);
        parts.push(part);
    }
    let merged = dir.join("merged");
    let mut merge = vec!["merge"];
    merge.extend(parts.iter().map(|p| p.to_str().unwrap()));
    merge.extend(["--out", merged.to_str().unwrap()]);
    icp_eval_ok(&merge);
    let merged_html = page(&merged);
    every_figure_inline(&merged_html, &merged);
    assert_eq!(
        select(&merged_html, "section > h2"),
        select(
            &Html::parse_document(&std::fs::read_to_string(cmp.join("report.html")).unwrap()),
            "section > h2"
        )
    );
}
