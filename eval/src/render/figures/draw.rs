//! What every figure shares: the `Figure` trait (a figure draws on any plotters backend),
//! writing one as PNG and SVG, the series' styles, legends and axes.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::error::EvalError;
use crate::render::outdir::{tmp_path, OutputDir};

pub(crate) const FONT: &str = "sans-serif";

/// Ten colours that stay apart on screen and in print: the Tableau 10 palette (Stone 2016,
/// the default of matplotlib and Vega).
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// How a series' line is drawn: its dash and gap lengths, pixels (none: solid).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Dash(pub(crate) Option<(u32, u32)>);

/// The dashes a series cycles through: solid, dashed, dotted.
const DASHES: [Dash; 3] = [Dash(None), Dash(Some((10, 5))), Dash(Some((3, 4)))];

/// The style of series `i` of a figure: the colour cycles through ten and the dash through
/// three, so every series of a figure up to the 30th differs from every other by its colour
/// or its dash, and neighbours by both.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SeriesStyle {
    pub(crate) color: RGBColor,
    pub(crate) dash: Dash,
}

/// The style of series `i` (see [`SeriesStyle`]).
pub(crate) fn series_style(i: usize) -> SeriesStyle {
    SeriesStyle {
        color: PALETTE[i % PALETTE.len()],
        dash: DASHES[i % DASHES.len()],
    }
}

/// A colour that is no series' own (a reference, a bound): black.
pub(crate) const NEUTRAL: RGBColor = BLACK;

pub(crate) fn err<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// A figure that can be drawn on any plotters backend.
pub(crate) trait Figure {
    fn size(&self) -> (u32, u32);
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String>;
}

/// Where figures go: files (PNG and SVG) or SVG text held in memory (for `report.html`).
pub(crate) trait Sink {
    /// Takes the figure `stem`, drawn as `fig`, with a lighter `svg_fig` for SVG output (one
    /// element per point adds up).
    fn figure(
        &mut self,
        stem: &str,
        fig: &impl Figure,
        svg_fig: &impl Figure,
    ) -> Result<(), EvalError>;
}

/// Writes each figure as `<stem>.png` and `<stem>.svg` into a run's directory, atomically.
pub(crate) struct Files<'a>(pub(crate) &'a mut OutputDir);

impl Sink for Files<'_> {
    fn figure(
        &mut self,
        stem: &str,
        fig: &impl Figure,
        svg_fig: &impl Figure,
    ) -> Result<(), EvalError> {
        write_png(self.0, stem, fig)?;
        self.0
            .write(&format!("{stem}.svg"), svg_text(stem, svg_fig)?.as_bytes())
    }
}

/// Renders `fig` to `<stem>.png` in `out`, atomically.
fn write_png(out: &mut OutputDir, stem: &str, fig: &impl Figure) -> Result<(), EvalError> {
    let png = out.file(&format!("{stem}.png"))?;
    let tmp = tmp_path(&png).with_extension("tmp.png");
    {
        let root = BitMapBackend::new(&tmp, fig.size()).into_drawing_area();
        fig.draw(&root).map_err(|w| plot_error(stem, w))?;
        root.present().map_err(|e| plot_error(stem, e))?;
    }
    std::fs::rename(&tmp, &png).map_err(|source| EvalError::Io { path: png, source })
}

/// Holds each figure's SVG text, in order: `(stem, svg)`.
#[derive(Default)]
pub(crate) struct SvgTexts(pub(crate) Vec<(String, String)>);

impl Sink for SvgTexts {
    fn figure(
        &mut self,
        stem: &str,
        _fig: &impl Figure,
        svg_fig: &impl Figure,
    ) -> Result<(), EvalError> {
        self.0.push((stem.to_owned(), svg_text(stem, svg_fig)?));
        Ok(())
    }
}

fn plot_error(stem: &str, what: impl std::fmt::Display) -> EvalError {
    EvalError::Plot {
        figure: stem.to_owned(),
        what: what.to_string(),
    }
}

/// `fig` drawn as SVG text.
fn svg_text(stem: &str, fig: &impl Figure) -> Result<String, EvalError> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, fig.size()).into_drawing_area();
        fig.draw(&root).map_err(|w| plot_error(stem, w))?;
        root.present().map_err(|e| plot_error(stem, e))?;
    }
    Ok(svg)
}

/// Renders `fig` to `<stem>.png` and `<stem>.svg` in `out`, atomically, and returns
/// `(stem, svg)` for `report.html`.
pub(crate) fn save(
    out: &mut OutputDir,
    stem: &str,
    fig: &impl Figure,
) -> Result<(String, String), EvalError> {
    write_png(out, stem, fig)?;
    let svg = svg_text(stem, fig)?;
    out.write(&format!("{stem}.svg"), svg.as_bytes())?;
    Ok((stem.to_owned(), svg))
}

/// Symmetric axis limit covering `values` (at least `floor`).
pub(crate) fn sym_limit(values: impl Iterator<Item = f64>, floor: f64) -> f64 {
    values.fold(floor, |m, v| m.max(v.abs())) * 1.05
}

/// Bounds of a set of points, padded and made square.
pub(crate) fn square_bounds(
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

pub(crate) type XyChart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// A square x–y chart in metres with its mesh drawn.
pub(crate) fn xy_chart<'a, DB: DrawingBackend>(
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

/// The chart's series labels in a framed box at `position`.
pub(crate) fn legend<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
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

/// A line through `pts` in series `i`'s style, labelled `label` in the legend with the same
/// colour and dash.
pub(crate) fn series_line<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    pts: Vec<(f64, f64)>,
    style: SeriesStyle,
    width: u32,
    label: &str,
) -> Result<(), String>
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let stroke = style.color.stroke_width(width);
    let annotation = match style.dash.0 {
        None => chart
            .draw_series(LineSeries::new(pts, stroke))
            .map_err(err)?,
        Some((dash, gap)) => chart
            .draw_series(DashedLineSeries::new(pts, dash, gap, stroke))
            .map_err(err)?,
    };
    let segments = legend_segments(style.dash);
    annotation.label(label).legend(move |(x, y)| {
        let [a, b, c, d] =
            segments.map(|(from, to)| PathElement::new(vec![(from, 0), (to, 0)], stroke));
        EmptyElement::at((x, y)) + a + b + c + d
    });
    Ok(())
}

/// The legend's sample of a line dashed `dash`: four segments over 24 px, end to end for a
/// solid line.
fn legend_segments(dash: Dash) -> [(i32, i32); 4] {
    let (on, off) = dash.0.map_or((6, 0), |(on, off)| (on as i32, off as i32));
    std::array::from_fn(|k| {
        let from = (k as i32 * (on + off)).min(24);
        (from, (from + on).min(24))
    })
}

/// A labelled line through `pts` in series style `style`, with a dot on each point.
pub(crate) fn dotted_line<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    pts: &[(f64, f64)],
    style: SeriesStyle,
    label: &str,
) -> Result<(), String>
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    series_line(chart, pts.to_vec(), style, 2, label)?;
    chart
        .draw_series(pts.iter().map(|&p| Circle::new(p, 4, style.color.filled())))
        .map_err(err)?;
    Ok(())
}
