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

use nalgebra::Point2;

use super::{check_reference, Correspondence, Matcher, NearestIndex};
use crate::cells::Cells;
use crate::registry::{Kind, NoParams, StageKind, StageSpec};
use crate::IcpError;

/// Grid nearest neighbour: the same pairs as brute force, with O(1) expected warm queries.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Grid;

/// The registered kind.
pub const KIND: Kind<NoParams, dyn Matcher> = Kind::new(
    "grid",
    "uniform grid whose queries keep their nearest point between iterations while a certificate proves it: exact, the default and the fastest here",
    |_, _| Box::new(Grid),
);

/// Most cells per point: bounds the build cost and memory.
const MAX_CELLS_PER_POINT: f64 = 8.0;

/// The bucketed reference points, and what the last [`NearestIndex::match_all`] learnt about
/// each query.
#[derive(Clone, Debug)]
pub struct GridIndex {
    cells: Cells,
    /// The points in reference order, for the distance to a known point.
    points: Vec<Point2<f64>>,
    /// One per query of the last call: a proof of its nearest point. A certificate bounds the
    /// distance of this index's points from its anchor, so it stays valid for any later query.
    certificates: Vec<Certificate>,
}

/// At `anchor`, every reference point other than `best` and `second` (the two nearest) was at
/// least `clearance` away. For a query `q` at `drift = |q − anchor|` those points are at least
/// `clearance − drift` from `q` (triangle inequality), so while the nearer of the two is nearer
/// than that, it is the nearest point. `best`/`dist_sq` are the last answer.
#[derive(Clone, Copy, Debug)]
struct Certificate {
    anchor: Point2<f64>,
    /// The clearance less the safety margin.
    limit: f64,
    best: usize,
    second: usize,
    /// The candidates' positions (the second's infinite when there is none), so that the
    /// test reads no other memory.
    best_at: Point2<f64>,
    second_at: Point2<f64>,
    dist_sq: f64,
}

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

/// Squared distance from `q` to `p`, computed as every matcher does.
#[inline]
fn dist_sq(p: &Point2<f64>, q: &Point2<f64>) -> f64 {
    let (dx, dy) = (p.x - q.x, p.y - q.y);
    dx * dx + dy * dy
}

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
        if d > self.d3 {
            return; // farther than the third: changes nothing
        }
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
    fn certificate(self, anchor: Point2<f64>, outside: f64, points: &[Point2<f64>]) -> Certificate {
        let far = Point2::new(f64::INFINITY, f64::INFINITY);
        if self.best == NONE {
            return Certificate {
                anchor,
                limit: 0.0,
                best: 0,
                second: NONE,
                best_at: points[0],
                second_at: far,
                dist_sq: f64::INFINITY,
            };
        }
        Certificate {
            anchor,
            limit: self.d3.sqrt().min(outside) * (1.0 - CERTIFICATE_MARGIN),
            best: self.best,
            second: self.second,
            best_at: points[self.best],
            second_at: if self.second == NONE {
                far
            } else {
                points[self.second]
            },
            dist_sq: self.d1,
        }
    }
}

impl Matcher for Grid {
    fn spec(&self) -> StageSpec {
        StageSpec::kind(KIND.name())
    }

    fn build(&self, reference: &[Point2<f64>]) -> Result<Box<dyn NearestIndex>, IcpError> {
        check_reference(reference)?;
        let n = reference.len() as f64;
        // Cells of side h with at most MAX_CELLS_PER_POINT · n of them over the bounding box.
        let cells = Cells::new(reference, |w, hgt| {
            (w * hgt / (MAX_CELLS_PER_POINT * n)).sqrt()
        });
        Ok(Box::new(GridIndex {
            cells,
            points: reference.to_vec(),
            certificates: Vec::new(),
        }))
    }
}

impl GridIndex {
    /// Squared distance from `q` to reference point `id`, computed as every matcher does.
    #[inline]
    fn dist_sq(&self, q: &Point2<f64>, id: usize) -> f64 {
        dist_sq(&self.points[id], q)
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
            let range = self.cells.row((cx0, cx1), cy);
            for (p, &id) in self.cells.points[range.clone()]
                .iter()
                .zip(&self.cells.ids[range])
            {
                found.offer(id as usize, dist_sq(p, q));
            }
        }
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
        let lo = self.cells.cell_xy(&Point2::new(q.x - r, q.y - r));
        let hi = self.cells.cell_xy(&Point2::new(q.x + r, q.y + r));
        let mut found = Nearest::EMPTY;
        self.scan_cells(q, (lo.0, hi.0), (lo.1, hi.1), &mut found);
        found.certificate(
            *q,
            self.cells.outside_bound(q, (lo.0, hi.0), (lo.1, hi.1)),
            &self.points,
        )
    }

    /// The two nearest points to `q` without a hint: rings of cells around `q`'s (clamped) cell
    /// until no unvisited cell can hold a point nearer than the second found.
    fn search_rings(&self, q: &Point2<f64>) -> Certificate {
        let (cx, cy) = self.cells.cell_xy(q);
        let mut found = Nearest::EMPTY;
        for k in 0.. {
            let (x_lo, x_hi) = (cx.saturating_sub(k), (cx + k).min(self.cells.nx - 1));
            let (y_lo, y_hi) = (cy.saturating_sub(k), (cy + k).min(self.cells.ny - 1));
            if k == 0 {
                self.scan_cells(q, (cx, cx), (cy, cy), &mut found);
            } else {
                // The ring: top and bottom rows, then the left and right columns between them.
                if cy >= k {
                    self.scan_cells(q, (x_lo, x_hi), (cy - k, cy - k), &mut found);
                }
                if cy + k < self.cells.ny {
                    self.scan_cells(q, (x_lo, x_hi), (cy + k, cy + k), &mut found);
                }
                let (r_lo, r_hi) = (
                    cy.saturating_sub(k - 1),
                    (cy + k - 1).min(self.cells.ny - 1),
                );
                if cx >= k {
                    self.scan_cells(q, (cx - k, cx - k), (r_lo, r_hi), &mut found);
                }
                if cx + k < self.cells.nx {
                    self.scan_cells(q, (cx + k, cx + k), (r_lo, r_hi), &mut found);
                }
            }
            // Every unvisited point lies beyond a side of the visited square that the grid
            // extends past.
            let bound = self.cells.outside_bound(q, (x_lo, x_hi), (y_lo, y_hi));
            if bound == f64::INFINITY || found.d3 <= bound * bound {
                return found.certificate(*q, bound, &self.points);
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
    fn match_all(&mut self, queries: &[Point2<f64>], out: &mut Vec<Correspondence>) {
        // Taken out and put back (no allocation) so the searches can borrow the index.
        let mut certificates = std::mem::take(&mut self.certificates);
        if certificates.len() == queries.len() {
            for (c, q) in certificates.iter_mut().zip(queries) {
                let (d_best, d_second) = (dist_sq(&c.best_at, q), dist_sq(&c.second_at, q));
                let (best, dist_sq) = if precedes(c.second, d_second, c.best, d_best) {
                    (c.second, d_second)
                } else {
                    (c.best, d_best)
                };
                let drift = (q - c.anchor).norm();
                if dist_sq.sqrt() + drift < c.limit {
                    // The same two candidates, the nearer first.
                    if best != c.best {
                        (c.best, c.second) = (c.second, c.best);
                        (c.best_at, c.second_at) = (c.second_at, c.best_at);
                    }
                    c.dist_sq = dist_sq;
                } else {
                    *c = self.search_from(q, best);
                }
            }
        } else {
            certificates.clear();
            certificates.reserve(queries.len());
            let mut previous: Option<usize> = None;
            for q in queries {
                let c = match previous {
                    Some(hint) => self.search_from(q, hint),
                    None => self.search_rings(q),
                };
                previous = c.dist_sq.is_finite().then_some(c.best);
                certificates.push(c);
            }
        }
        out.clear();
        out.extend(
            certificates
                .iter()
                .enumerate()
                .map(|(src, c)| Correspondence {
                    src,
                    dst: c.best,
                    dist_sq: c.dist_sq,
                }),
        );
        self.certificates = certificates;
    }
}
