//! Points bucketed into square cells of a uniform grid (a counting sort by cell), the layout
//! shared by the grid matcher and the surface estimation.

use nalgebra::Point2;

/// The points of a set, sorted by the cell that holds them (row-major), with their indices.
#[derive(Clone, Debug)]
pub struct Cells {
    /// The points in cell order.
    pub points: Vec<Point2<f64>>,
    /// The index in the input of each point of `points`.
    pub ids: Vec<u32>,
    /// `start[c]..start[c + 1]` are the points of cell `c` (row-major).
    start: Vec<u32>,
    x0: f64,
    y0: f64,
    /// Side of a cell, metres.
    pub h: f64,
    inv_h: f64,
    /// Cells along x.
    pub nx: usize,
    /// Cells along y.
    pub ny: usize,
    /// `nx − 1` and `ny − 1` as floats, for clamping.
    max_fx: f64,
    max_fy: f64,
}

/// Most cells along one side.
const MAX_CELLS_PER_SIDE: usize = 1 << 15;

/// Most cells in all (16 M: 64 MiB of cell starts, twice while sorting). Without it a scan
/// spread along both axes (one far spurious return at tens of kilometres) could ask for
/// 2^15 × 2^15 cells, 4 GiB. The largest grids of the data here have ~1.6 M cells (the CARMEN
/// aces log), far below it, so no result changes.
const MAX_CELLS: usize = 1 << 24;

impl Cells {
    /// Buckets `points` (non-empty, finite, at most `u32::MAX`) into cells whose side is
    /// `side(width, height)` of their bounding box, widened where the grid would have more than
    /// `2^15` cells along a side or `2^24` in all.
    pub fn new(points: &[Point2<f64>], side: impl FnOnce(f64, f64) -> f64) -> Self {
        let (mut x0, mut y0, mut x1, mut y1) = (
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        );
        for p in points {
            x0 = x0.min(p.x);
            y0 = y0.min(p.y);
            x1 = x1.max(p.x);
            y1 = y1.max(p.y);
        }
        let (w, hgt) = (
            (x1 - x0).max(f64::MIN_POSITIVE),
            (y1 - y0).max(f64::MIN_POSITIVE),
        );
        let mut h = side(w, hgt);
        if !(h.is_finite() && h > 0.0) {
            h = (w.max(hgt) / points.len() as f64).max(1e-9);
        }
        let cells = |extent: f64, h: f64| {
            ((extent / h).floor() as usize)
                .saturating_add(1)
                .min(MAX_CELLS_PER_SIDE)
        };
        if cells(w, h).saturating_mul(cells(hgt, h)) > MAX_CELLS {
            // Widened so that the product fits, (w / h' + 1)(hgt / h' + 1) ≤ MAX_CELLS: from
            // the side that makes w·hgt / h'² fit, up by 1 % until the floors' +1s fit too.
            h = h.max((w * hgt / MAX_CELLS as f64).sqrt());
            while cells(w, h).saturating_mul(cells(hgt, h)) > MAX_CELLS {
                h *= 1.01;
            }
        }
        let (nx, ny) = (cells(w, h), cells(hgt, h));
        let h = (w / nx as f64).max(hgt / ny as f64).max(h);
        let inv_h = 1.0 / h;
        let cell_of = |p: &Point2<f64>| -> usize {
            let cx = (((p.x - x0) * inv_h) as usize).min(nx - 1);
            let cy = (((p.y - y0) * inv_h) as usize).min(ny - 1);
            cy * nx + cx
        };
        let mut start = vec![0u32; nx * ny + 1];
        for p in points {
            start[cell_of(p) + 1] += 1;
        }
        for c in 0..nx * ny {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let n = points.len();
        let (mut sorted, mut ids) = (vec![Point2::origin(); n], vec![0u32; n]);
        for (i, p) in points.iter().enumerate() {
            let slot = &mut fill[cell_of(p)];
            let k = *slot as usize;
            sorted[k] = *p;
            ids[k] = i as u32; // the caller bounds the count to u32::MAX
            *slot += 1;
        }
        Self {
            points: sorted,
            ids,
            start,
            x0,
            y0,
            h,
            inv_h,
            nx,
            ny,
            max_fx: (nx - 1) as f64,
            max_fy: (ny - 1) as f64,
        }
    }

    /// Cells in all.
    #[cfg(test)]
    fn len(&self) -> usize {
        self.nx * self.ny
    }

    /// Cell coordinates of `q`, clamped into the grid.
    #[inline]
    pub fn cell_xy(&self, q: &Point2<f64>) -> (usize, usize) {
        // Clamped as floats (a NaN goes to 0), then converted: at most 2^15 cells a side.
        let fx = ((q.x - self.x0) * self.inv_h).max(0.0).min(self.max_fx);
        let fy = ((q.y - self.y0) * self.inv_h).max(0.0).min(self.max_fy);
        (fx as i32 as usize, fy as i32 as usize)
    }

    /// The positions in `points`/`ids` of the cells `cx0..=cx1` of row `cy`.
    #[inline]
    pub fn row(&self, (cx0, cx1): (usize, usize), cy: usize) -> std::ops::Range<usize> {
        let row = cy * self.nx;
        self.start[row + cx0] as usize..self.start[row + cx1 + 1] as usize
    }

    /// A lower bound on the distance from `q` to any point outside the cells
    /// `[x_lo, x_hi] × [y_lo, y_hi]`: the distance to the nearest side of that block which the
    /// grid extends past (infinite when the block covers the grid).
    #[inline]
    pub fn outside_bound(
        &self,
        q: &Point2<f64>,
        (x_lo, x_hi): (usize, usize),
        (y_lo, y_hi): (usize, usize),
    ) -> f64 {
        // Cell counts fit in u32 (at most 2^15 a side): cheap conversions.
        let edge = |c: usize| c as u32 as f64 * self.h;
        let inf = f64::INFINITY;
        let left = if x_lo > 0 {
            q.x - (self.x0 + edge(x_lo))
        } else {
            inf
        };
        let right = if x_hi + 1 < self.nx {
            self.x0 + edge(x_hi + 1) - q.x
        } else {
            inf
        };
        let below = if y_lo > 0 {
            q.y - (self.y0 + edge(y_lo))
        } else {
            inf
        };
        let above = if y_hi + 1 < self.ny {
            self.y0 + edge(y_hi + 1) - q.y
        } else {
            inf
        };
        // From infinity, as NaN-ignoring minima: a NaN query gets no bound (infinity).
        inf.min(left).min(right).min(below).min(above)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scan_spread_along_both_axes_gets_a_bounded_grid() {
        // Returns near the sensor and one spurious return 30 km away along the diagonal:
        // 0.1 m cells would be 300,000 a side.
        let mut points: Vec<Point2<f64>> = (0..100)
            .map(|i| Point2::new((i % 10) as f64 * 0.3, (i / 10) as f64 * 0.3))
            .collect();
        points.push(Point2::new(30_000.0, 30_000.0));
        let cells = Cells::new(&points, |_, _| 0.1);
        assert!(cells.len() <= MAX_CELLS, "{} cells", cells.len());
        assert!(cells.nx <= MAX_CELLS_PER_SIDE && cells.ny <= MAX_CELLS_PER_SIDE);
        // Every point is in the cell its coordinates say.
        let mut seen = vec![false; points.len()];
        for cy in 0..cells.ny {
            for k in cells.row((0, cells.nx - 1), cy) {
                let p = cells.points[k];
                assert_eq!(cells.cell_xy(&p).1, cy);
                seen[cells.ids[k] as usize] = true;
            }
        }
        assert!(seen.iter().all(|&s| s));
        // A small scan keeps the side it asked for.
        let small = Cells::new(&points[..100], |_, _| 0.1);
        assert!((small.h - 0.1).abs() < 1e-12, "{}", small.h);
    }
}
