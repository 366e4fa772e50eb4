//! Exact nearest neighbour on a uniform grid, warm-started by the previous match.
//!
//! The reference points are bucketed into square cells (struct of arrays, in cell order). A
//! cold query searches rings of cells outwards until no unvisited cell can hold a closer point.
//! A warm query starts from a hint (the previous iteration's match): any closer point lies
//! within the hint's distance, so only the cells overlapping that disc's bounding box are
//! searched — usually one or two once ICP has settled.

use nalgebra::Point2;

use super::{check_reference, Correspondence, Matcher, NearestIndex};
use crate::IcpError;

/// Grid nearest neighbour: the same pairs as brute force, with O(1) expected warm queries.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Grid;

/// Most cells per point: bounds the build cost and memory.
const MAX_CELLS_PER_POINT: f64 = 8.0;

/// The bucketed reference points.
#[derive(Clone, Debug)]
pub struct GridIndex {
    xs: Vec<f64>,
    ys: Vec<f64>,
    ids: Vec<u32>,
    /// `slots[id]`: where point `id` sits in cell order.
    slots: Vec<u32>,
    /// `cell_start[c]..cell_start[c + 1]` are the points of cell `c` (row-major).
    cell_start: Vec<u32>,
    x0: f64,
    y0: f64,
    inv_h: f64,
    h: f64,
    nx: usize,
    ny: usize,
}

impl Matcher for Grid {
    type Index = GridIndex;
    fn build(&self, reference: &[Point2<f64>]) -> Result<Self::Index, IcpError> {
        check_reference(reference)?;
        let (mut x0, mut y0, mut x1, mut y1) = (
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        );
        for p in reference {
            x0 = x0.min(p.x);
            y0 = y0.min(p.y);
            x1 = x1.max(p.x);
            y1 = y1.max(p.y);
        }
        let n = reference.len() as f64;
        let (w, hgt) = (
            (x1 - x0).max(f64::MIN_POSITIVE),
            (y1 - y0).max(f64::MIN_POSITIVE),
        );
        // Cells of side h with at most MAX_CELLS_PER_POINT · n of them over the bounding box.
        let mut h = (w * hgt / (MAX_CELLS_PER_POINT * n)).sqrt();
        if !(h.is_finite() && h > 0.0) {
            h = (w.max(hgt) / n).max(1e-9);
        }
        let cells = |extent: f64| {
            ((extent / h).floor() as usize)
                .saturating_add(1)
                .min(1 << 15)
        };
        let (nx, ny) = (cells(w), cells(hgt));
        let h = (w / nx as f64).max(hgt / ny as f64).max(h);
        let inv_h = 1.0 / h;
        let cell_of = |p: &Point2<f64>| -> usize {
            let cx = (((p.x - x0) * inv_h) as usize).min(nx - 1);
            let cy = (((p.y - y0) * inv_h) as usize).min(ny - 1);
            cy * nx + cx
        };
        // Counting sort of the points by cell.
        let mut cell_start = vec![0u32; nx * ny + 1];
        for p in reference {
            cell_start[cell_of(p) + 1] += 1;
        }
        for c in 0..nx * ny {
            cell_start[c + 1] += cell_start[c];
        }
        let mut fill = cell_start.clone();
        let n = reference.len();
        let (mut xs, mut ys, mut ids, mut slots) =
            (vec![0.0; n], vec![0.0; n], vec![0u32; n], vec![0u32; n]);
        for (i, p) in reference.iter().enumerate() {
            let slot = &mut fill[cell_of(p)];
            let k = *slot as usize;
            xs[k] = p.x;
            ys[k] = p.y;
            ids[k] = i as u32; // check_reference bounds the count to u32::MAX
            slots[i] = k as u32;
            *slot += 1;
        }
        Ok(GridIndex {
            xs,
            ys,
            ids,
            slots,
            cell_start,
            x0,
            y0,
            inv_h,
            h,
            nx,
            ny,
        })
    }
}

impl GridIndex {
    /// Cell coordinates of `q`, clamped into the grid.
    #[inline]
    fn cell_xy(&self, q: &Point2<f64>) -> (usize, usize) {
        let fx = ((q.x - self.x0) * self.inv_h).max(0.0);
        let fy = ((q.y - self.y0) * self.inv_h).max(0.0);
        (
            (fx as usize).min(self.nx - 1),
            (fy as usize).min(self.ny - 1),
        )
    }

    /// Scans the points of the cells `[cx0, cx1] × [cy0, cy1]`, improving `best`. Among points
    /// at the same distance the lowest index wins, as with brute force.
    #[inline]
    fn scan_cells(
        &self,
        q: &Point2<f64>,
        (cx0, cx1): (usize, usize),
        (cy0, cy1): (usize, usize),
        best: &mut (usize, f64),
    ) {
        for cy in cy0..=cy1 {
            let row = cy * self.nx;
            let (start, end) = (
                self.cell_start[row + cx0] as usize,
                self.cell_start[row + cx1 + 1] as usize,
            );
            let cells = self.xs[start..end]
                .iter()
                .zip(&self.ys[start..end])
                .zip(&self.ids[start..end]);
            for ((x, y), &id) in cells {
                let (dx, dy) = (x - q.x, y - q.y);
                let d = dx * dx + dy * dy;
                if d < best.1 || (d == best.1 && (id as usize) < best.0) {
                    *best = (id as usize, d);
                }
            }
        }
    }

    /// The nearest point to `q` that is closer than `best` (or `best` itself).
    fn search_box(&self, q: &Point2<f64>, mut best: (usize, f64)) -> (usize, f64) {
        let r = best.1.sqrt();
        let lo = self.cell_xy(&Point2::new(q.x - r, q.y - r));
        let hi = self.cell_xy(&Point2::new(q.x + r, q.y + r));
        self.scan_cells(q, (lo.0, hi.0), (lo.1, hi.1), &mut best);
        best
    }

    /// Cold query: rings of cells around `q`'s (clamped) cell until no unvisited cell can hold a
    /// closer point.
    fn search_rings(&self, q: &Point2<f64>) -> (usize, f64) {
        let (cx, cy) = self.cell_xy(q);
        let mut best = (usize::MAX, f64::INFINITY);
        for k in 0.. {
            let (x_lo, x_hi) = (cx.saturating_sub(k), (cx + k).min(self.nx - 1));
            let (y_lo, y_hi) = (cy.saturating_sub(k), (cy + k).min(self.ny - 1));
            if k == 0 {
                self.scan_cells(q, (cx, cx), (cy, cy), &mut best);
            } else {
                // The ring: top and bottom rows, then the left and right columns between them.
                if cy >= k {
                    self.scan_cells(q, (x_lo, x_hi), (cy - k, cy - k), &mut best);
                }
                if cy + k < self.ny {
                    self.scan_cells(q, (x_lo, x_hi), (cy + k, cy + k), &mut best);
                }
                let (r_lo, r_hi) = (cy.saturating_sub(k - 1), (cy + k - 1).min(self.ny - 1));
                if cx >= k {
                    self.scan_cells(q, (cx - k, cx - k), (r_lo, r_hi), &mut best);
                }
                if cx + k < self.nx {
                    self.scan_cells(q, (cx + k, cx + k), (r_lo, r_hi), &mut best);
                }
            }
            // Every unvisited point lies beyond a side of the visited square that the grid
            // extends past; its distance is at least the distance from q to that side.
            let mut bound = f64::INFINITY;
            if x_lo > 0 {
                bound = bound.min(q.x - (self.x0 + x_lo as f64 * self.h));
            }
            if x_hi + 1 < self.nx {
                bound = bound.min(self.x0 + (x_hi + 1) as f64 * self.h - q.x);
            }
            if y_lo > 0 {
                bound = bound.min(q.y - (self.y0 + y_lo as f64 * self.h));
            }
            if y_hi + 1 < self.ny {
                bound = bound.min(self.y0 + (y_hi + 1) as f64 * self.h - q.y);
            }
            if bound == f64::INFINITY || (best.0 != usize::MAX && best.1 <= bound * bound) {
                break;
            }
        }
        // Only a non-finite query finds nothing; it gets index 0 at infinite distance, as
        // from the brute-force search.
        if best.0 == usize::MAX {
            best.0 = 0;
        }
        best
    }
}

impl NearestIndex for GridIndex {
    fn nearest(&self, query: &Point2<f64>) -> (usize, f64) {
        self.search_rings(query)
    }

    /// Warm-started when `out` holds one correspondence per query from the previous call. A
    /// cold call warm-starts each query from the previous query's answer: consecutive returns
    /// of a scan are neighbours, and so are their nearest reference points.
    fn match_all(&self, moved_src: &[Point2<f64>], out: &mut Vec<Correspondence>) {
        let from_hint = |q: &Point2<f64>, hint: usize| {
            let k = self.slots[hint] as usize;
            let (dx, dy) = (self.xs[k] - q.x, self.ys[k] - q.y);
            self.search_box(q, (hint, dx * dx + dy * dy))
        };
        if out.len() == moved_src.len() {
            for (c, q) in out.iter_mut().zip(moved_src) {
                let (dst, dist_sq) = from_hint(q, c.dst);
                *c = Correspondence {
                    src: c.src,
                    dst,
                    dist_sq,
                };
            }
        } else {
            out.clear();
            let mut previous: Option<usize> = None;
            for (src, q) in moved_src.iter().enumerate() {
                let (dst, dist_sq) = match previous {
                    Some(hint) => from_hint(q, hint),
                    None => self.search_rings(q),
                };
                previous = dist_sq.is_finite().then_some(dst);
                out.push(Correspondence { src, dst, dist_sq });
            }
        }
    }
}
