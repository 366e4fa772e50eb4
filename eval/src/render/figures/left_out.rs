//! One scan drawn in its scanner's frame with the returns a detector of moving returns left
//! out of its registrations marked (`crate::run::moving`): where the dataset labels the
//! returns of moving objects, the missed ones and the static ones left out are told apart.

use datasets::Dataset;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::render::figures::draw::*;
use crate::run::left_out::DrawnScan;

/// The figure: `drawn`, a scan of `ds`.
pub(crate) struct LeftOutScan<'a> {
    pub(crate) ds: &'a Dataset,
    pub(crate) drawn: &'a DrawnScan,
}

/// What a return is, as drawn.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Class {
    Kept,
    LeftOut,
    /// Left out, labelled static.
    StaticLeftOut,
    /// Kept, labelled moving.
    Missed,
}

impl Class {
    const ALL: [Class; 4] = [
        Class::Kept,
        Class::LeftOut,
        Class::StaticLeftOut,
        Class::Missed,
    ];

    fn style(self) -> (RGBColor, u32, &'static str) {
        match self {
            Class::Kept => (RGBColor(150, 150, 150), 2, "kept"),
            Class::LeftOut => (RGBColor(214, 39, 40), 3, "left out"),
            Class::StaticLeftOut => (RGBColor(255, 127, 14), 3, "left out, labelled static"),
            Class::Missed => (RGBColor(31, 119, 180), 3, "kept, labelled moving (missed)"),
        }
    }
}

impl LeftOutScan<'_> {
    /// Each return's point and class.
    fn classified(&self) -> Vec<((f64, f64), Class)> {
        let scan = &self.ds.scans[self.drawn.scan];
        let mut out = vec![false; scan.len()];
        for &i in &self.drawn.left_out {
            if let Some(o) = out.get_mut(i as usize) {
                *o = true;
            }
        }
        let labels = scan.moving();
        scan.returns()
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let moving = labels.map(|l| l[i]);
                let class = match (out[i], moving) {
                    (true, Some(false)) => Class::StaticLeftOut,
                    (true, _) => Class::LeftOut,
                    (false, Some(true)) => Class::Missed,
                    (false, _) => Class::Kept,
                };
                ((r.point.x, r.point.y), class)
            })
            .collect()
    }
}

impl Figure for LeftOutScan<'_> {
    fn size(&self) -> (u32, u32) {
        (1000, 1000)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        root.fill(&WHITE).map_err(err)?;
        let points = self.classified();
        let left_out = points.iter().filter(|(_, c)| *c != Class::Kept).count()
            - points.iter().filter(|(_, c)| *c == Class::Missed).count();
        let title = format!(
            "Returns left out as moving — {}, scan {} by {}: {left_out} of {}",
            self.ds.provenance.name,
            self.drawn.scan,
            self.drawn.variant,
            points.len()
        );
        let root = root.titled(&title, (FONT, 20)).map_err(err)?;
        let (xr, yr) = square_bounds(points.iter().map(|(p, _)| *p).chain([(0.0, 0.0)]));
        let mut chart = xy_chart(&root, "in the scanner's frame", xr, yr)?;
        for class in Class::ALL {
            let (color, radius, label) = class.style();
            let mine: Vec<(f64, f64)> = points
                .iter()
                .filter(|(_, c)| *c == class)
                .map(|(p, _)| *p)
                .collect();
            if mine.is_empty() {
                continue;
            }
            let n = mine.len();
            chart
                .draw_series(
                    mine.into_iter()
                        .map(|p| Circle::new(p, radius, color.filled())),
                )
                .map_err(err)?
                .label(format!("{label} ({n})"))
                .legend(move |(x, y)| Circle::new((x + 10, y), 4, color.filled()));
        }
        chart
            .draw_series([TriangleMarker::new((0.0, 0.0), 8, NEUTRAL.filled())])
            .map_err(err)?
            .label("the scanner")
            .legend(|(x, y)| TriangleMarker::new((x + 10, y), 6, NEUTRAL.filled()));
        legend(&mut chart, SeriesLabelPosition::UpperRight)
    }
}
