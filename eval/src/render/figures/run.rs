//! The figures of one run, drawn from its [`RunReport`]: SOG and ΔCOG error against scan index
//! (the paper's Figs. 12, 14), their histograms (Figs. 13, 15), the chained trajectories, the
//! maps made by placing every scan on them (Fig. 16), the NEES distribution, and a scan with
//! the returns left out as moving.

use datasets::Dataset;
use nalgebra::Point2;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::error::EvalError;
use crate::measure::record::PairRecord;
use crate::measure::report::RunReport;
use crate::render::figures::draw::*;
use crate::render::figures::left_out::LeftOutScan;
use crate::render::outdir::OutputDir;

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
            crate::measure::stats::quantile_sorted(&e, 0.01),
            crate::measure::stats::quantile_sorted(&e, 0.99),
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
            let color = series_style(i).color;
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
            let color = series_style(i).color;
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
            series_line(
                &mut chart,
                t.iter()
                    .map(|(_, p)| (p.translation.x, p.translation.y))
                    .collect(),
                series_style(i),
                2,
                &format!("{} ({:.1} m)", v.name, v.trajectory.length_m),
            )?;
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
    let score = |v: &crate::measure::report::VariantSummary| {
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
                xs.map(|x| (x, crate::measure::consistency::chi2_cdf(3.0, x))),
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
            series_line(
                &mut chart,
                steps,
                series_style(vi),
                2,
                &format!("{} ({} pairs)", v.name, nees.len()),
            )?;
        }
        legend(&mut chart, SeriesLabelPosition::LowerRight)?;
        Ok(())
    }
}

/// Draws every figure of the report into `dir` (PNG and SVG).
pub fn write_all(out: &mut OutputDir, ds: &Dataset, report: &RunReport) -> Result<(), EvalError> {
    draw_all(&mut Files(out), ds, report)
}

/// Every figure of the report as SVG text, `(stem, svg)` in order (for `report.html`).
pub fn svgs(ds: &Dataset, report: &RunReport) -> Result<Vec<(String, String)>, EvalError> {
    let mut texts = SvgTexts::default();
    draw_all(&mut texts, ds, report)?;
    Ok(texts.0)
}

/// Draws every figure of the report into `sink`.
fn draw_all(sink: &mut impl Sink, ds: &Dataset, report: &RunReport) -> Result<(), EvalError> {
    for kind in [SOG, DCOG] {
        let fig = ErrorVsScan { report, kind };
        sink.figure(kind.stem, &fig, &fig)?;
        let hist = Histograms { report, kind };
        sink.figure(&format!("{}_hist", kind.stem), &hist, &hist)?;
    }
    let reference = if report.reference.rigid_pose {
        ds.reference
            .as_ref()
            .map(|r| r.iter().map(|p| (p.x_m, p.y_m)).collect())
    } else {
        None
    };
    let trajectories = Trajectories { report, reference };
    sink.figure("trajectory", &trajectories, &trajectories)?;
    if report.pairs.iter().any(|r| r.nees.is_some()) {
        let nees = NeesCdf { report };
        sink.figure("nees", &nees, &nees)?;
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
    sink.figure("map", &png, &svg)?;
    if let Some(drawn) = &report.drawn_scan {
        let scan = LeftOutScan { ds, drawn };
        sink.figure("left_out", &scan, &scan)?;
    }
    Ok(())
}
