//! Exact nearest neighbour on a uniform grid, with certificates that spare most searches of
//! an ICP iteration.
//!
//! The reference points are bucketed into square cells (sorted into cell order). A search
//! finds a query's two nearest points and a clearance: a lower bound on the distance of every
//! other point. A cold search visits rings of cells outwards until no unvisited cell can hold a
//! point nearer than the third found; a hinted one (from the neighbouring query's or the
//! previous iteration's match) only the cells within the hint's distance, its clearance bounded
//! by the nearest unvisited cell. Between ICP iterations a query moves little: while the nearer
//! of its two candidates plus its drift stays inside the clearance found at its last search,
//! no other point can be nearer, and the query costs two distances. Two candidates, not one:
//! a query between two points of a wall is nearly equidistant from them, and would otherwise
//! be searched again at every iteration. Once ICP settles almost every query is answered so.

use std::sync::atomic::{AtomicU64, Ordering};

use nalgebra::Point2;

use super::{check_reference, Certificate, Correspondence, Matcher, Matches, NearestIndex};
use crate::IcpError;

/// Grid nearest neighbour: the same pairs as brute force, with O(1) expected warm queries.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Grid;

/// Most cells per point: bounds the build cost and memory.
const MAX_CELLS_PER_POINT: f64 = 8.0;

/// The bucketed reference points.
#[derive(Clone, Debug)]
pub struct GridIndex {
    /// The points in cell order, and their indices in the reference.
    cell_points: Vec<Point2<f64>>,
    ids: Vec<u32>,
    /// The points in reference order, for the distance to a known point.
    points: Vec<Point2<f64>>,
    /// `cell_start[c]..cell_start[c + 1]` are the points of cell `c` (row-major).
    cell_start: Vec<u32>,
    x0: f64,
    y0: f64,
    inv_h: f64,
    h: f64,
    nx: usize,
    ny: usize,
    /// Distinguishes this index's certificates in a reused [`Matches`] from another's.
    stamp: u64,
}

/// Stamps of built indices; 0 is never given.
static NEXT_STAMP: AtomicU64 = AtomicU64::new(1);

/// Relative safety margin of the certificate test, far above the rounding of the distances
/// (a few ulps): a certified point is nearer than any other by more than rounding can blur.
const CERTIFICATE_MARGIN: f64 = 1e-9;

/// The two points nearest to a query among those offered (ordered by distance, then index)
/// and a lower bound on the squared distance of every other one offered.
#[derive(Clone, Copy, Debug)]
struct Nearest {
    best: usize,
    d1: f64,
    second: usize,
    d2: f64,
    d3: f64,
}

/// No point.
const NONE: usize = usize::MAX;

/// True when point `a` at squared distance `da` comes before point `b` at `db`.
#[inline]
fn precedes(a: usize, da: f64, b: usize, db: f64) -> bool {
    da < db || (da == db && a < b)
}

impl Nearest {
    const EMPTY: Self = Self {
        best: NONE,
        d1: f64::INFINITY,
        second: NONE,
        d2: f64::INFINITY,
        d3: f64::INFINITY,
    };

    #[inline]
    fn offer(&mut self, id: usize, d: f64) {
        // Written as selects, not branches: which point wins is unpredictable.
        let first = precedes(id, d, self.best, self.d1);
        let second = !first && precedes(id, d, self.second, self.d2);
        self.d3 = if first || second {
            self.d2
        } else {
            self.d3.min(d)
        };
        (self.second, self.d2) = if first {
            (self.best, self.d1)
        } else if second {
            (id, d)
        } else {
            (self.second, self.d2)
        };
        (self.best, self.d1) = if first { (id, d) } else { (self.best, self.d1) };
    }

    /// The certificate at `anchor`, every point outside the visited cells being at least
    /// `outside` away. A non-finite query finds nothing: index 0 at infinite distance, as from
    /// the brute-force search, and no clearance.
    fn certificate(self, anchor: Point2<f64>, outside: f64) -> Certificate {
        if self.best == NONE {
            return Certificate {
                anchor,
                clearance: 0.0,
                best: 0,
                second: NONE,
                dist_sq: f64::INFINITY,
            };
        }
        Certificate {
            anchor,
            clearance: self.d3.sqrt().min(outside),
            best: self.best,
            second: self.second,
            dist_sq: self.d1,
        }
    }
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
        let (mut cell_points, mut ids) = (vec![Point2::origin(); n], vec![0u32; n]);
        for (i, p) in reference.iter().enumerate() {
            let slot = &mut fill[cell_of(p)];
            let k = *slot as usize;
            cell_points[k] = *p;
            ids[k] = i as u32; // check_reference bounds the count to u32::MAX
            *slot += 1;
        }
        Ok(GridIndex {
            cell_points,
            ids,
            points: reference.to_vec(),
            cell_start,
            x0,
            y0,
            inv_h,
            h,
            nx,
            ny,
            stamp: NEXT_STAMP.fetch_add(1, Ordering::Relaxed),
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

    /// Squared distance from `q` to reference point `id`, computed as every matcher does.
    #[inline]
    fn dist_sq(&self, q: &Point2<f64>, id: usize) -> f64 {
        let p = self.points[id];
        let (dx, dy) = (p.x - q.x, p.y - q.y);
        dx * dx + dy * dy
    }

    /// Offers the points of the cells `[cx0, cx1] × [cy0, cy1]` to `found`.
    #[inline]
    fn scan_cells(
        &self,
        q: &Point2<f64>,
        (cx0, cx1): (usize, usize),
        (cy0, cy1): (usize, usize),
        found: &mut Nearest,
    ) {
        for cy in cy0..=cy1 {
            let row = cy * self.nx;
            let (start, end) = (
                self.cell_start[row + cx0] as usize,
                self.cell_start[row + cx1 + 1] as usize,
            );
            for (p, &id) in self.cell_points[start..end]
                .iter()
                .zip(&self.ids[start..end])
            {
                let (dx, dy) = (p.x - q.x, p.y - q.y);
                found.offer(id as usize, dx * dx + dy * dy);
            }
        }
    }

    /// A lower bound on the distance from `q` to any point outside the cells
    /// `[x_lo, x_hi] × [y_lo, y_hi]`: the distance to the nearest side of that block which the
    /// grid extends past (infinite when the block covers the grid).
    fn outside_bound(
        &self,
        q: &Point2<f64>,
        (x_lo, x_hi): (usize, usize),
        (y_lo, y_hi): (usize, usize),
    ) -> f64 {
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
        bound
    }

    /// The nearest point to `q`, searched from reference point `hint`: any nearer point lies
    /// within the hint's distance, so only the cells overlapping that disc's bounding box are
    /// visited. The clearance is the nearer of the second point found there and the block's
    /// unvisited outside.
    fn search_from(&self, q: &Point2<f64>, hint: usize) -> Certificate {
        let reach_sq = self.dist_sq(q, hint);
        if !reach_sq.is_finite() {
            return self.search_rings(q);
        }
        let r = reach_sq.sqrt();
        let lo = self.cell_xy(&Point2::new(q.x - r, q.y - r));
        let hi = self.cell_xy(&Point2::new(q.x + r, q.y + r));
        let mut found = Nearest::EMPTY;
        self.scan_cells(q, (lo.0, hi.0), (lo.1, hi.1), &mut found);
        found.certificate(*q, self.outside_bound(q, (lo.0, hi.0), (lo.1, hi.1)))
    }

    /// The two nearest points to `q` without a hint: rings of cells around `q`'s (clamped) cell
    /// until no unvisited cell can hold a point nearer than the second found.
    fn search_rings(&self, q: &Point2<f64>) -> Certificate {
        let (cx, cy) = self.cell_xy(q);
        let mut found = Nearest::EMPTY;
        for k in 0.. {
            let (x_lo, x_hi) = (cx.saturating_sub(k), (cx + k).min(self.nx - 1));
            let (y_lo, y_hi) = (cy.saturating_sub(k), (cy + k).min(self.ny - 1));
            if k == 0 {
                self.scan_cells(q, (cx, cx), (cy, cy), &mut found);
            } else {
                // The ring: top and bottom rows, then the left and right columns between them.
                if cy >= k {
                    self.scan_cells(q, (x_lo, x_hi), (cy - k, cy - k), &mut found);
                }
                if cy + k < self.ny {
                    self.scan_cells(q, (x_lo, x_hi), (cy + k, cy + k), &mut found);
                }
                let (r_lo, r_hi) = (cy.saturating_sub(k - 1), (cy + k - 1).min(self.ny - 1));
                if cx >= k {
                    self.scan_cells(q, (cx - k, cx - k), (r_lo, r_hi), &mut found);
                }
                if cx + k < self.nx {
                    self.scan_cells(q, (cx + k, cx + k), (r_lo, r_hi), &mut found);
                }
            }
            // Every unvisited point lies beyond a side of the visited square that the grid
            // extends past.
            let bound = self.outside_bound(q, (x_lo, x_hi), (y_lo, y_hi));
            if bound == f64::INFINITY || found.d3 <= bound * bound {
                return found.certificate(*q, bound);
            }
        }
        unreachable!("the rings end once they cover the grid")
    }
}

impl NearestIndex for GridIndex {
    fn nearest(&self, query: &Point2<f64>) -> (usize, f64) {
        let c = self.search_rings(query);
        (c.best, c.dist_sq)
    }

    /// A query keeps the nearer of its two candidates while its certificate holds (two
    /// distances); otherwise, and at a first call, it is searched from a hint: that candidate,
    /// or at a first call the previous query's answer (consecutive returns of a scan are
    /// neighbours, and so are their nearest reference points).
    fn match_all(&self, moved_src: &[Point2<f64>], out: &mut Matches) {
        let certificates = &mut out.certificates;
        if out.owner == self.stamp && certificates.len() == moved_src.len() {
            for (c, q) in certificates.iter_mut().zip(moved_src) {
                let (mut best, mut dist_sq) = (c.best, self.dist_sq(q, c.best));
                if c.second != NONE {
                    let d = self.dist_sq(q, c.second);
                    if precedes(c.second, d, best, dist_sq) {
                        (best, dist_sq) = (c.second, d);
                    }
                }
                let drift = (q - c.anchor).norm();
                if dist_sq.sqrt() + drift < c.clearance * (1.0 - CERTIFICATE_MARGIN) {
                    // The same two candidates, the nearer first.
                    if best != c.best {
                        (c.best, c.second) = (best, c.best);
                    }
                    c.dist_sq = dist_sq;
                } else {
                    *c = self.search_from(q, best);
                }
            }
        } else {
            out.owner = self.stamp;
            certificates.clear();
            let mut previous: Option<usize> = None;
            for q in moved_src {
                let c = match previous {
                    Some(hint) => self.search_from(q, hint),
                    None => self.search_rings(q),
                };
                previous = c.dist_sq.is_finite().then_some(c.best);
                certificates.push(c);
            }
        }
        out.pairs.clear();
        out.pairs.extend(
            certificates
                .iter()
                .enumerate()
                .map(|(src, c)| Correspondence {
                    src,
                    dst: c.best,
                    dist_sq: c.dist_sq,
                }),
        );
    }
}
