//! The figures of the studies over runs: a sweep's error spread against its parameter, the
//! convergence basin's success against the start's offset, and a scaling run's cost against
//! the scan's size.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::error::EvalError;
use crate::render::figures::draw::*;
use crate::render::outdir::OutputDir;

struct SweepFigure<'a> {
    result: &'a crate::measure::sweep::SweepResult,
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
        type Get = fn(&crate::measure::sweep::SweepPoint) -> Option<f64>;
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
                crate::measure::stats::quantile_sorted(&all, 0.5)
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
                    dotted_line(&mut chart, &values(v, *get), series_style(i), v)?;
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

/// Draws `sweep.png` and `sweep.svg`; returns `(stem, svg)` for `report.html`.
pub fn write_sweep(
    out: &mut OutputDir,
    result: &crate::measure::sweep::SweepResult,
) -> Result<(String, String), EvalError> {
    save(out, "sweep", &SweepFigure { result })
}

struct BasinFigure<'a> {
    report: &'a crate::measure::basin::BasinReport,
}

impl Figure for BasinFigure<'_> {
    fn size(&self) -> (u32, u32) {
        (1500, 520)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        use crate::measure::basin::BasinBin;
        use crate::measure::basin::VariantBasin;
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
                dotted_line(&mut chart, &pts, series_style(i), &v.name)?;
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
            let pts: Vec<(f64, f64)> = (0..=100)
                .map(|k| {
                    let x = x_max * k as f64 / 100.0;
                    (x, 100.0 * e.partition_point(|&t| t <= x) as f64 / n)
                })
                .collect();
            series_line(&mut chart, pts, series_style(i), 2, &v.name)?;
        }
        legend(&mut chart, SeriesLabelPosition::LowerRight)?;
        Ok(())
    }
}

/// Draws `basin.png` and `basin.svg`; returns `(stem, svg)` for `report.html`.
pub fn write_basin(
    out: &mut OutputDir,
    report: &crate::measure::basin::BasinReport,
) -> Result<(String, String), EvalError> {
    save(out, "basin", &BasinFigure { report })
}

struct ScalingFigure<'a> {
    result: &'a crate::measure::scaling::ScalingResult,
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
        let n = |p: &crate::measure::scaling::ScalingPoint| p.returns.max(1) as f64;
        let (x0, x1) = pts.iter().fold((f64::INFINITY, 1.0f64), |(a, b), p| {
            (a.min(n(p)), b.max(n(p)))
        });
        let xr = (x0 / 1.5).max(1.0)..x1 * 1.5;
        let per_iteration =
            |p: &crate::measure::scaling::ScalingPoint| p.median_us / (p.iterations + 1) as f64;
        // An n log n guide through the first per-iteration time.
        let guide = |x: f64| {
            pts.first().map_or(f64::NAN, |p| {
                per_iteration(p) * x * x.ln() / (n(p) * n(p).ln().max(1.0))
            })
        };
        type Get<'g> = Box<dyn Fn(&crate::measure::scaling::ScalingPoint) -> f64 + 'g>;
        type Series<'g> = Vec<(&'static str, SeriesStyle, Get<'g>)>;
        let panels: [(&str, Series); 3] = [
            (
                "time (µs)",
                vec![
                    (
                        "per registration",
                        series_style(0),
                        Box::new(|p| p.median_us),
                    ),
                    ("per iteration", series_style(1), Box::new(per_iteration)),
                ],
            ),
            (
                "iterations",
                vec![(
                    "iterations",
                    series_style(2),
                    Box::new(|p| p.iterations as f64),
                )],
            ),
            (
                "ns per point and iteration",
                vec![(
                    "ns per point and iteration",
                    series_style(3),
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
                        NEUTRAL.stroke_width(1),
                    ))
                    .map_err(err)?
                    .label("n log n")
                    .legend(|(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], NEUTRAL.stroke_width(1))
                    });
            }
            legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
        }
        Ok(())
    }
}

/// Draws `scaling.png` and `scaling.svg`; returns `(stem, svg)` for `report.html`.
pub fn write_scaling(
    out: &mut OutputDir,
    result: &crate::measure::scaling::ScalingResult,
) -> Result<(String, String), EvalError> {
    save(out, "scaling", &ScalingFigure { result })
}
