//! The paper's figures, drawn from a [`RunReport`] with plotters, each as PNG and SVG:
//! SOG and ΔCOG error against scan index (Figs. 12, 14), their histograms (Figs. 13, 15), the
//! chained trajectories, and the maps made by placing every scan on them (Fig. 16).

use datasets::Dataset;
use nalgebra::Point2;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::output::tmp_path;
use crate::report::{PairRecord, RunReport};
use crate::EvalError;
use crate::OutputDir;

const FONT: &str = "sans-serif";
const COLORS: [RGBColor; 6] = [
    RGBColor(200, 40, 40),
    RGBColor(230, 140, 20),
    RGBColor(40, 140, 60),
    RGBColor(30, 90, 200),
    RGBColor(120, 60, 160),
    RGBColor(90, 90, 90),
];

fn err<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// A figure that can be drawn on any plotters backend.
trait Figure {
    fn size(&self) -> (u32, u32);
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String>;
}

/// Renders `fig` to `<stem>.png` and `<stem>.svg` in `out`, atomically.
fn save(out: &mut OutputDir, stem: &str, fig: &impl Figure) -> Result<(), EvalError> {
    save_pair(out, stem, fig, fig)
}

/// Like [`save`], with a lighter figure for the SVG (one element per point adds up).
fn save_pair(
    out: &mut OutputDir,
    stem: &str,
    fig: &impl Figure,
    svg_fig: &impl Figure,
) -> Result<(), EvalError> {
    let plot_err = |what: String| EvalError::Plot {
        figure: stem.to_owned(),
        what,
    };
    let png = out.file(&format!("{stem}.png"))?;
    let tmp = tmp_path(&png).with_extension("tmp.png");
    {
        let root = BitMapBackend::new(&tmp, fig.size()).into_drawing_area();
        fig.draw(&root).map_err(plot_err)?;
        root.present().map_err(|e| plot_err(e.to_string()))?;
    }
    std::fs::rename(&tmp, &png).map_err(|source| EvalError::Io {
        path: png.clone(),
        source,
    })?;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, svg_fig.size()).into_drawing_area();
        svg_fig.draw(&root).map_err(plot_err)?;
        root.present().map_err(|e| plot_err(e.to_string()))?;
    }
    out.write(&format!("{stem}.svg"), svg.as_bytes())
}

/// Which error a figure shows.
#[derive(Clone, Copy)]
struct ErrorKind {
    stem: &'static str,
    label: &'static str,
    get: fn(&PairRecord) -> Option<f64>,
}

const SOG: ErrorKind = ErrorKind {
    stem: "sog_error",
    label: "SOG error (m/s)",
    get: |r| r.sog_err_mps,
};
const DCOG: ErrorKind = ErrorKind {
    stem: "dcog_error",
    label: "ΔCOG error (°)",
    get: |r| r.dcog_err_deg,
};

/// Symmetric axis limit covering `values` (at least `floor`).
fn sym_limit(values: impl Iterator<Item = f64>, floor: f64) -> f64 {
    values.fold(floor, |m, v| m.max(v.abs())) * 1.05
}

/// Per variant, its `kind` errors over the run's population (the pairs every variant
/// registered, as in every statistic): `(scan index, error, reference step plausible)`.
fn population_errors(report: &RunReport, kind: ErrorKind) -> Vec<Vec<(f64, f64, bool)>> {
    report
        .variants
        .iter()
        .map(|v| {
            report
                .pairs
                .iter()
                .filter(|r| r.variant == v.name && r.all_registered)
                .filter_map(|r| (kind.get)(r).map(|e| (r.source as f64, e, r.ref_plausible)))
                .collect()
        })
        .collect()
}

/// The 1st and 99th percentiles of every variant's errors together, widened to a symmetric
/// range: one scale for every panel of a figure, which a few gross failures do not flatten.
fn shared_range(errors: &[Vec<(f64, f64, bool)>]) -> f64 {
    let mut e: Vec<f64> = errors.iter().flatten().map(|p| p.1).collect();
    e.sort_by(f64::total_cmp);
    if e.is_empty() {
        return 1.0;
    }
    sym_limit(
        [
            crate::stats::quantile_sorted(&e, 0.01),
            crate::stats::quantile_sorted(&e, 0.99),
        ]
        .into_iter(),
        1e-3,
    )
}

struct ErrorVsScan<'a> {
    report: &'a RunReport,
    kind: ErrorKind,
}

impl Figure for ErrorVsScan<'_> {
    fn size(&self) -> (u32, u32) {
        (1200, 220 * self.report.variants.len().max(1) as u32 + 60)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(err)?;
        let title = format!(
            "{} against scan index — {} (○: reference step flagged implausible)",
            self.kind.label, self.report.dataset.name
        );
        let errors = population_errors(self.report, self.kind);
        let lim = shared_range(&errors);
        let title = format!("{title}; one scale, errors beyond ±{lim:.3} drawn at the edge");
        let root = root.titled(&title, (FONT, 20)).map_err(err)?;
        let n = self.report.variants.len().max(1);
        let x_max = self.report.dataset.scans.max(2) as f64;
        for (i, ((panel, v), pts)) in root
            .split_evenly((n, 1))
            .iter()
            .zip(&self.report.variants)
            .zip(&errors)
            .enumerate()
        {
            let pts: Vec<(f64, f64, bool)> = pts
                .iter()
                .map(|&(x, e, plausible)| (x, e.clamp(-lim, lim), plausible))
                .collect();
            let mut chart = ChartBuilder::on(panel)
                .caption(&v.name, (FONT, 18))
                .margin(6)
                .x_label_area_size(32)
                .y_label_area_size(70)
                .build_cartesian_2d(0.0..x_max, -lim..lim)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc("scan index")
                .y_desc(self.kind.label)
                .draw()
                .map_err(err)?;
            let color = COLORS[i % COLORS.len()];
            chart
                .draw_series(LineSeries::new(
                    pts.iter().map(|p| (p.0, p.1)),
                    color.stroke_width(1),
                ))
                .map_err(err)?;
            // Pairs with an implausible reference step: hollow black circles.
            chart
                .draw_series(
                    pts.iter()
                        .filter(|p| !p.2)
                        .map(|p| Circle::new((p.0, p.1), 4, BLACK.stroke_width(1))),
                )
                .map_err(err)?;
        }
        Ok(())
    }
}

struct Histograms<'a> {
    report: &'a RunReport,
    kind: ErrorKind,
}

impl Figure for Histograms<'_> {
    fn size(&self) -> (u32, u32) {
        (1200, 900)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(err)?;
        let title = format!(
            "Histogram of the {} — {}",
            self.kind.label, self.report.dataset.name
        );
        let root = root.titled(&title, (FONT, 24)).map_err(err)?;
        let n = self.report.variants.len().max(1);
        let cols = if n > 1 { 2 } else { 1 };
        let rows = n.div_ceil(cols);
        let errors = population_errors(self.report, self.kind);
        // One range for every panel: the 1st to 99th percentile of every variant's errors.
        let lim = shared_range(&errors);
        let (lo, hi) = (-lim, lim);
        for (i, ((panel, v), e)) in root
            .split_evenly((rows, cols))
            .iter()
            .zip(&self.report.variants)
            .zip(&errors)
            .enumerate()
        {
            let e: Vec<f64> = e.iter().map(|p| p.1).collect();
            const BINS: usize = 30;
            let w = (hi - lo) / BINS as f64;
            let mut counts = [0usize; BINS];
            let mut outside = 0;
            for &x in &e {
                if x < lo || x > hi {
                    outside += 1;
                } else {
                    counts[(((x - lo) / w) as usize).min(BINS - 1)] += 1;
                }
            }
            let top = *counts.iter().max().unwrap_or(&1) as f64 * 1.1 + 1.0;
            let caption = format!(
                "{} (n = {}, {} outside the range)",
                v.name,
                e.len(),
                outside
            );
            let mut chart = ChartBuilder::on(panel)
                .caption(caption, (FONT, 16))
                .margin(8)
                .x_label_area_size(34)
                .y_label_area_size(50)
                .build_cartesian_2d(lo..hi, 0.0..top)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc(self.kind.label)
                .y_desc("pairs")
                .draw()
                .map_err(err)?;
            let color = COLORS[i % COLORS.len()];
            chart
                .draw_series(counts.iter().enumerate().map(|(b, &c)| {
                    let x0 = lo + b as f64 * w;
                    Rectangle::new([(x0, 0.0), (x0 + w, c as f64)], color.mix(0.7).filled())
                }))
                .map_err(err)?;
        }
        Ok(())
    }
}

/// Bounds of a set of points, padded and made square.
fn square_bounds(
    points: impl Iterator<Item = (f64, f64)>,
) -> (std::ops::Range<f64>, std::ops::Range<f64>) {
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for (x, y) in points {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !x0.is_finite() {
        return (-1.0..1.0, -1.0..1.0);
    }
    let half = 0.5 * (x1 - x0).max(y1 - y0) * 1.08 + 1.0;
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    (cx - half..cx + half, cy - half..cy + half)
}

type XyChart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// A square x–y chart in metres with its mesh drawn.
fn xy_chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    caption: &str,
    xr: std::ops::Range<f64>,
    yr: std::ops::Range<f64>,
) -> Result<XyChart<'a, DB>, String> {
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FONT, 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(xr, yr)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("x (m)")
        .y_desc("y (m)")
        .draw()
        .map_err(err)?;
    Ok(chart)
}

struct Trajectories<'a> {
    report: &'a RunReport,
    reference: Option<Vec<(f64, f64)>>,
}

impl Figure for Trajectories<'_> {
    fn size(&self) -> (u32, u32) {
        (1000, 1000)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(err)?;
        let all = self
            .report
            .trajectories
            .iter()
            .flatten()
            .map(|(_, p)| (p.translation.x, p.translation.y))
            .chain(self.reference.iter().flatten().copied());
        let (xr, yr) = square_bounds(all);
        let caption = match &self.reference {
            Some(_) => format!(
                "Chained trajectories and reference — {}",
                self.report.dataset.name
            ),
            None => format!(
                "Chained trajectories (scan 0 frame; the reference is not a rigid pose) — {}",
                self.report.dataset.name
            ),
        };
        let mut chart = xy_chart(root, &caption, xr, yr)?;
        if let Some(r) = &self.reference {
            chart
                .draw_series(LineSeries::new(r.iter().copied(), BLACK.stroke_width(3)))
                .map_err(err)?
                .label("reference")
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(3))
                });
        }
        for (i, (v, t)) in self
            .report
            .variants
            .iter()
            .zip(&self.report.trajectories)
            .enumerate()
        {
            let color = COLORS[i % COLORS.len()];
            chart
                .draw_series(LineSeries::new(
                    t.iter().map(|(_, p)| (p.translation.x, p.translation.y)),
                    color.stroke_width(2),
                ))
                .map_err(err)?
                .label(format!("{} ({:.1} m)", v.name, v.trajectory.length_m))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .draw()
            .map_err(err)?;
        Ok(())
    }
}

/// Most points drawn per map panel in the PNG (every n-th return beyond that).
const MAP_MAX_POINTS_PNG: usize = 40_000;
/// Most points per map panel in the SVG, where each point is an element.
const MAP_MAX_POINTS_SVG: usize = 4_000;

/// One map panel: a variant's name, its placed returns and its track.
struct MapPanel {
    name: String,
    points: Vec<(f64, f64)>,
    track: Vec<(f64, f64)>,
}

struct Maps<'a> {
    report: &'a RunReport,
    panels: Vec<MapPanel>,
}

impl Figure for Maps<'_> {
    fn size(&self) -> (u32, u32) {
        (1000 * self.panels.len().max(1) as u32, 1000)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(err)?;
        let title = format!("Maps from the chained scans — {}", self.report.dataset.name);
        let root = root.titled(&title, (FONT, 24)).map_err(err)?;
        let areas = root.split_evenly((1, self.panels.len().max(1)));
        for (
            area,
            MapPanel {
                name,
                points,
                track,
            },
        ) in areas.iter().zip(&self.panels)
        {
            let (xr, yr) = square_bounds(points.iter().chain(track).copied());
            let mut chart = xy_chart(area, name, xr, yr)?;
            chart
                .draw_series(points.iter().map(|&p| Pixel::new(p, BLACK)))
                .map_err(err)?;
            chart
                .draw_series(LineSeries::new(track.iter().copied(), RED.stroke_width(2)))
                .map_err(err)?;
        }
        Ok(())
    }
}

/// The map of one variant: every scan's returns placed on its chained pose.
fn map_points(
    ds: &Dataset,
    report: &RunReport,
    variant: usize,
    max_points: usize,
) -> Vec<(f64, f64)> {
    let traj = &report.trajectories[variant];
    let first = report
        .pairs
        .iter()
        .find(|r| r.variant == report.variants[variant].name)
        .map_or(0, |r| r.source);
    let scans: Vec<usize> = std::iter::once(first)
        .chain(
            report
                .pairs
                .iter()
                .filter(|r| r.variant == report.variants[variant].name)
                .map(|r| r.reference),
        )
        .collect();
    let total: usize = scans.iter().map(|&k| ds.scans[k].len()).sum();
    let step = total.div_ceil(max_points).max(1);
    let mut out = Vec::with_capacity(total / step + 1);
    let mut i = 0;
    for (&k, (_, pose)) in scans.iter().zip(traj) {
        for ret in ds.scans[k].returns() {
            if i % step == 0 {
                let p = pose * Point2::new(ret.point.x, ret.point.y);
                out.push((p.x, p.y));
            }
            i += 1;
        }
    }
    out
}

/// The variants whose maps are drawn: the most and the least accurate by the median |ΔCOG
/// error| over the pairs with a plausible reference (over all pairs when none is plausible),
/// in run order; the first two of the run when there is no reference.
fn map_variants(report: &RunReport) -> Vec<usize> {
    let score = |v: &crate::report::VariantSummary| {
        v.plausible_reference
            .dcog_err_deg
            .or(v.all_pairs.dcog_err_deg)
            .map(|s| s.median_abs)
    };
    let scored: Vec<(usize, f64)> = report
        .variants
        .iter()
        .enumerate()
        .filter_map(|(i, v)| score(v).map(|s| (i, s)))
        .collect();
    let best = scored.iter().min_by(|a, b| a.1.total_cmp(&b.1));
    let worst = scored.iter().max_by(|a, b| a.1.total_cmp(&b.1));
    match (best, worst) {
        (Some(&(b, _)), Some(&(w, _))) => {
            let mut chosen = vec![b.min(w), b.max(w)];
            chosen.dedup();
            chosen
        }
        _ => (0..report.variants.len().min(2)).collect(),
    }
}

/// Draws every figure of the report into `dir`.
pub fn write_all(out: &mut OutputDir, ds: &Dataset, report: &RunReport) -> Result<(), EvalError> {
    for kind in [SOG, DCOG] {
        save(out, kind.stem, &ErrorVsScan { report, kind })?;
        save(
            out,
            &format!("{}_hist", kind.stem),
            &Histograms { report, kind },
        )?;
    }
    let reference = if report.reference.rigid_pose {
        ds.reference
            .as_ref()
            .map(|r| r.iter().map(|p| (p.x_m, p.y_m)).collect())
    } else {
        None
    };
    save(out, "trajectory", &Trajectories { report, reference })?;
    if report.pairs.iter().any(|r| r.nees.is_some()) {
        save(out, "nees", &NeesCdf { report })?;
    }
    let chosen = map_variants(report);
    let panels = |max_points: usize| -> Vec<_> {
        chosen
            .iter()
            .map(|&vi| {
                let track = report.trajectories[vi]
                    .iter()
                    .map(|(_, p)| (p.translation.x, p.translation.y))
                    .collect();
                MapPanel {
                    name: report.variants[vi].name.clone(),
                    points: map_points(ds, report, vi, max_points),
                    track,
                }
            })
            .collect()
    };
    let png = Maps {
        report,
        panels: panels(MAP_MAX_POINTS_PNG),
    };
    let svg = Maps {
        report,
        panels: panels(MAP_MAX_POINTS_SVG),
    };
    save_pair(out, "map", &png, &svg)
}

/// The chart's series labels in a framed box at `position`.
fn legend<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> Result<(), String> {
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .draw()
        .map_err(err)
}

/// A labelled line through `pts` with a dot on each point.
fn dotted_line<DB, X, Y>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    pts: &[(f64, f64)],
    color: RGBColor,
    label: &str,
) -> Result<(), String>
where
    DB: DrawingBackend,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    chart
        .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))
        .map_err(err)?
        .label(label)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
    chart
        .draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))
        .map_err(err)?;
    Ok(())
}

struct SweepFigure<'a> {
    result: &'a crate::sweep::SweepResult,
}

impl Figure for SweepFigure<'_> {
    fn size(&self) -> (u32, u32) {
        (1200, 1000)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(err)?;
        let name = &self.result.param.name;
        let title = format!("Error spread against {name} (pairs with a plausible reference)");
        let root = root.titled(&title, (FONT, 22)).map_err(err)?;
        let mut variants: Vec<&str> = Vec::new();
        for p in &self.result.points {
            if !variants.contains(&p.variant.as_str()) {
                variants.push(&p.variant);
            }
        }
        let (x0, x1) = self
            .result
            .points
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.value), b.max(p.value))
            });
        let pad = ((x1 - x0) * 0.05).max(1e-3);
        type Get = fn(&crate::sweep::SweepPoint) -> Option<f64>;
        let series: [(&str, Get); 2] = [
            ("SOG error std (m/s)", |p| p.sog_std_mps),
            ("ΔCOG error std (°)", |p| p.dcog_std_deg),
        ];
        let values = |v: &str, get: Get| -> Vec<(f64, f64)> {
            self.result
                .points
                .iter()
                .filter(|p| p.variant == v)
                .filter_map(|p| get(p).map(|y| (p.value, y)))
                .collect()
        };
        // Top row: every variant. Bottom row: zoomed on the variants whose spread stays within
        // twice the median of all, so a much worse one (K_ICP) does not flatten the others.
        let grid = root.split_evenly((2, 2));
        for (col, (label, get)) in series.iter().enumerate() {
            let mut all: Vec<f64> = self.result.points.iter().filter_map(get).collect();
            all.sort_by(f64::total_cmp);
            let median = if all.is_empty() {
                0.0
            } else {
                crate::stats::quantile_sorted(&all, 0.5)
            };
            for row in 0..2 {
                let shown: Vec<(usize, &str)> = variants
                    .iter()
                    .copied()
                    .enumerate()
                    .filter(|(_, v)| {
                        row == 0 || values(v, *get).iter().all(|p| p.1 <= 2.0 * median)
                    })
                    .collect();
                let ys: Vec<f64> = shown
                    .iter()
                    .flat_map(|(_, v)| values(v, *get))
                    .map(|p| p.1)
                    .collect();
                let (lo, hi) = ys
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &y| {
                        (a.min(y), b.max(y))
                    });
                let (lo, hi) = if lo.is_finite() {
                    let m = ((hi - lo) * 0.1).max(hi.abs() * 0.01).max(1e-9);
                    (if row == 0 { 0.0 } else { lo - m }, hi + m)
                } else {
                    (0.0, 1.0)
                };
                let caption = if row == 0 {
                    "all variants".to_owned()
                } else {
                    "zoom: variants within 2x the median spread".to_owned()
                };
                let mut chart = ChartBuilder::on(&grid[row * 2 + col])
                    .caption(caption, (FONT, 15))
                    .margin(10)
                    .x_label_area_size(40)
                    .y_label_area_size(70)
                    .build_cartesian_2d(x0 - pad..x1 + pad, lo..hi)
                    .map_err(err)?;
                chart
                    .configure_mesh()
                    .x_desc(name)
                    .y_desc(*label)
                    .draw()
                    .map_err(err)?;
                for (i, v) in shown {
                    let color = COLORS[i % COLORS.len()];
                    dotted_line(&mut chart, &values(v, *get), color, v)?;
                }
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.9))
                    .border_style(BLACK)
                    .draw()
                    .map_err(err)?;
            }
        }
        Ok(())
    }
}

/// Draws `sweep.png` and `sweep.svg`.
pub fn write_sweep(
    out: &mut OutputDir,
    result: &crate::sweep::SweepResult,
) -> Result<(), EvalError> {
    save(out, "sweep", &SweepFigure { result })
}

struct BasinFigure<'a> {
    report: &'a crate::basin::BasinReport,
}

impl Figure for BasinFigure<'_> {
    fn size(&self) -> (u32, u32) {
        (1500, 520)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        use crate::basin::{BasinBin, VariantBasin};
        root.fill(&WHITE).map_err(err)?;
        let r = self.report;
        let title = format!(
            "Convergence basin — {} ({} pairs × {} starts; success: within {} m and {}°)",
            r.dataset, r.pairs, r.options.perturbations, r.success_trans_m, r.success_rot_deg
        );
        let root = root.titled(&title, (FONT, 22)).map_err(err)?;
        let panels = root.split_evenly((1, 3));
        type Bins = fn(&VariantBasin) -> &Vec<BasinBin>;
        let curves: [(&str, f64, Bins); 2] = [
            (
                "start's translation offset (m)",
                r.options.max_translation_m,
                |v| &v.by_translation_m,
            ),
            (
                "start's |rotation offset| (°)",
                r.options.max_rotation_deg,
                |v| &v.by_rotation_deg,
            ),
        ];
        for (panel, (label, max, bins)) in panels.iter().zip(curves) {
            let mut chart = ChartBuilder::on(panel)
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d(0.0..max.max(1e-9), 0.0..105.0)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc(label)
                .y_desc("success (%)")
                .draw()
                .map_err(err)?;
            for (i, v) in r.variants.iter().enumerate() {
                let pts: Vec<(f64, f64)> = bins(v)
                    .iter()
                    .filter_map(|b| b.success_rate.map(|s| (0.5 * (b.lo + b.hi), 100.0 * s)))
                    .collect();
                dotted_line(&mut chart, &pts, COLORS[i % COLORS.len()], &v.name)?;
            }
            legend(&mut chart, SeriesLabelPosition::LowerLeft)?;
        }
        // Cumulative translation error of the registered results, up to 4× the threshold.
        let x_max = 4.0 * r.success_trans_m;
        let mut chart = ChartBuilder::on(&panels[2])
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..x_max, 0.0..105.0)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("translation error (m)")
            .y_desc("starts with a smaller error (%)")
            .draw()
            .map_err(err)?;
        for (i, v) in r.variants.iter().enumerate() {
            let mut e: Vec<f64> = r
                .rows
                .iter()
                .filter(|row| row.variant == v.name)
                .map(|row| row.trans_err_m.unwrap_or(f64::INFINITY))
                .collect();
            e.sort_by(f64::total_cmp);
            let n = e.len().max(1) as f64;
            let color = COLORS[i % COLORS.len()];
            let pts: Vec<(f64, f64)> = (0..=100)
                .map(|k| {
                    let x = x_max * k as f64 / 100.0;
                    (x, 100.0 * e.partition_point(|&t| t <= x) as f64 / n)
                })
                .collect();
            chart
                .draw_series(LineSeries::new(pts, color.stroke_width(2)))
                .map_err(err)?
                .label(v.name.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
        }
        legend(&mut chart, SeriesLabelPosition::LowerRight)?;
        Ok(())
    }
}

/// Draws `basin.png` and `basin.svg`.
pub fn write_basin(
    out: &mut OutputDir,
    report: &crate::basin::BasinReport,
) -> Result<(), EvalError> {
    save(out, "basin", &BasinFigure { report })
}

struct ScalingFigure<'a> {
    result: &'a crate::scaling::ScalingResult,
}

impl Figure for ScalingFigure<'_> {
    fn size(&self) -> (u32, u32) {
        (1500, 520)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(err)?;
        let title = format!(
            "{}: cost against scan size (synthetic harbour, one registration)",
            self.result.variant
        );
        let root = root.titled(&title, (FONT, 22)).map_err(err)?;
        let pts = &self.result.points;
        let n = |p: &crate::scaling::ScalingPoint| p.returns.max(1) as f64;
        let (x0, x1) = pts.iter().fold((f64::INFINITY, 1.0f64), |(a, b), p| {
            (a.min(n(p)), b.max(n(p)))
        });
        let xr = (x0 / 1.5).max(1.0)..x1 * 1.5;
        let per_iteration =
            |p: &crate::scaling::ScalingPoint| p.median_us / (p.iterations + 1) as f64;
        // An n log n guide through the first per-iteration time.
        let guide = |x: f64| {
            pts.first().map_or(f64::NAN, |p| {
                per_iteration(p) * x * x.ln() / (n(p) * n(p).ln().max(1.0))
            })
        };
        type Get<'g> = Box<dyn Fn(&crate::scaling::ScalingPoint) -> f64 + 'g>;
        type Series<'g> = Vec<(&'static str, RGBColor, Get<'g>)>;
        let panels: [(&str, Series); 3] = [
            (
                "time (µs)",
                vec![
                    ("per registration", COLORS[0], Box::new(|p| p.median_us)),
                    ("per iteration", COLORS[3], Box::new(per_iteration)),
                ],
            ),
            (
                "iterations",
                vec![("iterations", COLORS[2], Box::new(|p| p.iterations as f64))],
            ),
            (
                "ns per point and iteration",
                vec![(
                    "ns per point and iteration",
                    COLORS[4],
                    Box::new(|p| p.ns_per_point_iteration),
                )],
            ),
        ];
        for (i, (area, (label, series))) in root.split_evenly((1, 3)).iter().zip(panels).enumerate()
        {
            let ys: Vec<f64> = series
                .iter()
                .flat_map(|(_, _, get)| pts.iter().map(get))
                .filter(|y| y.is_finite() && *y > 0.0)
                .collect();
            let hi = ys.iter().copied().fold(1.0f64, f64::max) * 1.5;
            let lo = ys.iter().copied().fold(f64::INFINITY, f64::min).min(hi) / 1.5;
            let mut chart = ChartBuilder::on(area)
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(xr.clone().log_scale(), (lo..hi).log_scale())
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc("returns per scan")
                .y_desc(label)
                .x_label_formatter(&|v| format!("{v:.0}"))
                .y_label_formatter(&|v| format!("{v:.0}"))
                .draw()
                .map_err(err)?;
            for (name, color, get) in &series {
                let xy: Vec<(f64, f64)> = pts.iter().map(|p| (n(p), get(p))).collect();
                dotted_line(&mut chart, &xy, *color, name)?;
            }
            if i == 0 {
                let xs = (0..=40).map(|k| xr.start * (xr.end / xr.start).powf(k as f64 / 40.0));
                chart
                    .draw_series(DashedLineSeries::new(
                        xs.map(|x| (x, guide(x))).filter(|p| p.1 > lo && p.1 < hi),
                        6,
                        4,
                        COLORS[5].stroke_width(1),
                    ))
                    .map_err(err)?
                    .label("n log n")
                    .legend(|(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], COLORS[5].stroke_width(1))
                    });
            }
            legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
        }
        Ok(())
    }
}

/// Draws `scaling.png` and `scaling.svg`.
pub fn write_scaling(
    out: &mut OutputDir,
    result: &crate::scaling::ScalingResult,
) -> Result<(), EvalError> {
    save(out, "scaling", &ScalingFigure { result })
}

/// Largest NEES shown: the χ²(3) CDF is 0.9985 there; larger values sit at the right edge.
const NEES_AXIS_MAX: f64 = 16.0;

/// The cumulative distribution of each variant's NEES (pairs with a rigid reference and a
/// bounded covariance) against χ²(3), the distribution a consistent covariance gives
/// (Bar-Shalom, Li & Kirubarajan 2001, §5.4): a curve left of χ²(3) is under-confident,
/// right of it over-confident.
struct NeesCdf<'a> {
    report: &'a RunReport,
}

impl Figure for NeesCdf<'_> {
    fn size(&self) -> (u32, u32) {
        (900, 600)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(err)?;
        let title = format!(
            "NEES against χ²(3) — {} (covariance: {})",
            self.report.dataset.name, self.report.config.covariance
        );
        let root = root.titled(&title, (FONT, 20)).map_err(err)?;
        let mut chart = ChartBuilder::on(&root)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..NEES_AXIS_MAX, 0.0..1.0)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("NEES of t_ref_src (x, y, θ)")
            .y_desc("fraction of pairs with a smaller NEES")
            .draw()
            .map_err(err)?;
        let xs = (0..=160).map(|k| k as f64 * NEES_AXIS_MAX / 160.0);
        chart
            .draw_series(LineSeries::new(
                xs.map(|x| (x, crate::consistency::chi2_cdf(3.0, x))),
                BLACK.stroke_width(3),
            ))
            .map_err(err)?
            .label("χ²(3)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(3)));
        for (vi, v) in self.report.variants.iter().enumerate() {
            let mut nees: Vec<f64> = self
                .report
                .pairs
                .iter()
                .filter(|r| r.variant == v.name)
                .filter_map(|r| r.nees)
                .collect();
            if nees.is_empty() {
                continue;
            }
            nees.sort_by(f64::total_cmp);
            let n = nees.len() as f64;
            let steps: Vec<(f64, f64)> = nees
                .iter()
                .enumerate()
                .map(|(i, &x)| (x.min(NEES_AXIS_MAX), (i + 1) as f64 / n))
                .collect();
            let color = COLORS[vi % COLORS.len()];
            chart
                .draw_series(LineSeries::new(steps, color.stroke_width(2)))
                .map_err(err)?
                .label(format!("{} ({} pairs)", v.name, nees.len()))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
        }
        legend(&mut chart, SeriesLabelPosition::LowerRight)?;
        Ok(())
    }
}
