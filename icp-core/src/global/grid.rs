//! The likelihood grid of a reference scan and its pyramid of max-pooled grids.
//!
//! Level 0 is Olson's (2009) rasterised cost table: each cell of side `resolution_m` holds
//! `max_p exp(−d²/(2σ²))`, `d` the distance from the cell's centre to reference point `p`,
//! truncated to 0 beyond [`TRUNCATION_SIGMAS`] σ and quantised to `u8` (255 = 1). Level `h`
//! is Hess et al.'s (2016) precomputation grid: its cell `(i, j)` holds the maximum of the
//! level-0 cells `[i, i + 2^h) × [j, j + 2^h)`, so a source scan's sum over level `h` at a
//! translation bounds its level-0 sum at every translation of the `2^h × 2^h` block starting
//! there. Cells outside the grid are 0 at every level.
//!
//! Sums are integers, so the bounds of the branch-and-bound search are exact comparisons.

use nalgebra::{Isometry2, Point2};

use super::likelihood::{EXPONENT_BELOW, QUANTISED_EXP};
pub use super::likelihood::{FULL_SCALE, TRUNCATION_SIGMAS};
use crate::error::ScanRole;
use crate::scan::Return;
use crate::{IcpError, Scan};

/// Most cells along a side of a level.
const MAX_SIDE_CELLS: f64 = (1 << 26) as f64;

/// Cell coordinates are clamped to ±this: far outside any level (see [`MAX_SIDE_CELLS`]) even
/// after a window offset (at most 2^12 cells) and a level's offset (less than 2^14 cells), and
/// far from `i32` overflow.
const FAR_CELL: f64 = (1 << 28) as f64;

/// One level of the pyramid: `data[(j + offset) * nx + i + offset]` is the cell `(i, j)` for
/// `i` in `−offset..nx − offset` (and likewise `j`).
#[derive(Clone, Debug, PartialEq)]
struct Level {
    data: Vec<u8>,
    nx: u32,
    ny: u32,
    offset: i32,
}

impl Level {
    /// The value of cell `(i, j)`, 0 outside the level.
    #[inline]
    fn value(&self, [i, j]: [i32; 2]) -> u8 {
        // A negative index wraps to a large u32 and fails the test: one compare per axis.
        let (a, b) = ((i + self.offset) as u32, (j + self.offset) as u32);
        if a < self.nx && b < self.ny {
            self.data[b as usize * self.nx as usize + a as usize]
        } else {
            0
        }
    }

    /// The sum over `cells`, each shifted by `offset` and weighted by `weights`.
    #[inline]
    fn sum(&self, cells: &[[i32; 2]], weights: &[u32], [dx, dy]: [i32; 2]) -> u64 {
        cells
            .iter()
            .zip(weights)
            .map(|(&[i, j], &w)| u64::from(self.value([i + dx, j + dy])) * u64::from(w))
            .sum()
    }

    /// The level above `self` (`self` pools blocks of `s` cells, the result `2s`):
    /// `max` of the cells at `(i, j)`, `(i + s, j)`, `(i, j + s)` and `(i + s, j + s)`, pooled
    /// along x then along y.
    fn pooled(&self, s: u32) -> Level {
        let (nx, ny, s) = (self.nx as usize, self.ny as usize, s as usize);
        let (mx, my) = (nx + s, ny + s);
        let mut along_x = Vec::with_capacity(mx * ny);
        for row in self.data.chunks_exact(nx) {
            max_shifted(&mut along_x, row, s);
        }
        // Along y the rows are shifted by s rows: the same operation on the whole array.
        let mut data = Vec::with_capacity(mx * my);
        max_shifted(&mut data, &along_x, s * mx);
        Level {
            data,
            nx: mx as u32,
            ny: my as u32,
            offset: self.offset + s as i32,
        }
    }
}

/// Appends to `out` `max(v[a − s], v[a])` for `a` in `0..v.len() + s`, a missing `v` being 0:
/// in array indices, the pooled cell `a` of a level offset by `s` more than `v`'s. Written
/// once each, without zeroing the cells first.
fn max_shifted(out: &mut Vec<u8>, v: &[u8], s: usize) {
    let n = v.len();
    let lead = s.min(n);
    out.extend_from_slice(&v[..lead]);
    out.extend(v[lead..].iter().zip(v).map(|(&a, &b)| a.max(b)));
    out.extend(std::iter::repeat_n(0, s.saturating_sub(n)));
    out.extend_from_slice(&v[n - lead..]);
}

/// The likelihood grid of one reference scan with its max-pooled pyramid (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct LikelihoodGrid {
    /// Level `h` pools blocks of `2^h` cells; level 0 is the likelihood itself.
    levels: Vec<Level>,
    /// The lower-left corner of cell `(0, 0)`, reference frame, metres.
    origin: Point2<f64>,
    resolution_m: f64,
    sigma_m: f64,
}

impl LikelihoodGrid {
    /// The grid of `reference`'s points with cells of `resolution_m`, the likelihood's
    /// `sigma_m` and `depth` max-pooled levels above level 0 (parameters assumed valid:
    /// see [`super::GlobalParams::validate`]).
    ///
    /// `Err(TooFewPoints)` for a scan without returns, `Err(GlobalSearchTooLarge)` when the levels
    /// together would hold more than `max_cells` cells.
    pub(crate) fn new(
        reference: &Scan,
        resolution_m: f64,
        sigma_m: f64,
        depth: u32,
        max_cells: u64,
    ) -> Result<Self, IcpError> {
        let points: Vec<Point2<f64>> = reference
            .returns()
            .iter()
            .map(|r| r.point)
            .filter(|p| p.x.is_finite() && p.y.is_finite())
            .collect();
        if points.is_empty() {
            return Err(IcpError::TooFewPoints {
                role: ScanRole::Reference,
                got: 0,
                need: 1,
            });
        }
        let reach_m = TRUNCATION_SIGMAS * sigma_m;
        let (mut lo, mut hi) = (points[0], points[0]);
        for p in &points {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let origin = Point2::new(lo.x - reach_m, lo.y - reach_m);
        let cells = |extent_m: f64| ((extent_m + 2.0 * reach_m) / resolution_m).floor() + 1.0;
        let (fx, fy) = (cells(hi.x - lo.x), cells(hi.y - lo.y));
        let top_pad = ((1u64 << depth) - 1) as f64;
        let side = fx.max(fy) + top_pad;
        if side > MAX_SIDE_CELLS {
            return Err(IcpError::GlobalSearchTooLarge {
                what: "grid cells along a side",
                count: side,
                max: MAX_SIDE_CELLS,
            });
        }
        // Every level holds (n + 2^h − 1) cells a side.
        let total: f64 = (0..=depth)
            .map(|h| {
                let pad = ((1u64 << h) - 1) as f64;
                (fx + pad) * (fy + pad)
            })
            .sum();
        if total > max_cells as f64 {
            return Err(IcpError::GlobalSearchTooLarge {
                what: "grid cells (max_grid_cells)",
                count: total,
                max: max_cells as f64,
            });
        }
        let (nx, ny) = (fx as usize, fy as usize);
        let mut data = vec![0u8; nx * ny];
        let inv_two_var = 1.0 / (2.0 * sigma_m * sigma_m);
        let reach_sq = reach_m * reach_m;
        let (below, quantised_exp) = (&*EXPONENT_BELOW, &*QUANTISED_EXP);
        // The cells whose centre may be within reach of coordinate c along one axis.
        let span = |c: f64, n: usize| {
            let first = ((c - reach_m) / resolution_m).floor().max(0.0) as usize;
            let last = ((c + reach_m) / resolution_m).floor().min(n as f64 - 1.0) as usize;
            first..=last
        };
        for p in &points {
            let (px, py) = (p.x - origin.x, p.y - origin.y);
            for j in span(py, ny) {
                let dy = (j as f64 + 0.5) * resolution_m - py;
                let row = &mut data[j * nx..(j + 1) * nx];
                for i in span(px, nx) {
                    let dx = (i as f64 + 0.5) * resolution_m - px;
                    let d_sq = dx * dx + dy * dy;
                    let exponent = d_sq * inv_two_var;
                    // Beyond `below[v]` the likelihood quantises to at most v: the cell keeps
                    // its value, and the likelihood is not looked up.
                    if d_sq <= reach_sq && exponent <= below[usize::from(row[i])] {
                        row[i] = row[i].max(quantised_exp.of(exponent));
                    }
                }
            }
        }
        let mut levels = vec![Level {
            data,
            nx: nx as u32,
            ny: ny as u32,
            offset: 0,
        }];
        for h in 1..=depth {
            let next = levels[h as usize - 1].pooled(1 << (h - 1));
            levels.push(next);
        }
        Ok(Self {
            levels,
            origin,
            resolution_m,
            sigma_m,
        })
    }

    /// Side of a cell, metres.
    pub fn resolution_m(&self) -> f64 {
        self.resolution_m
    }

    /// The likelihood's σ, metres.
    pub fn sigma_m(&self) -> f64 {
        self.sigma_m
    }

    /// Max-pooled levels above level 0.
    pub fn depth(&self) -> u32 {
        self.levels.len() as u32 - 1
    }

    /// Cells along x and y of level 0.
    pub fn size(&self) -> (usize, usize) {
        (self.levels[0].nx as usize, self.levels[0].ny as usize)
    }

    /// The cell holding `q` (reference frame): integer cell coordinates, clamped far outside
    /// the grid when `q` is far away or not finite.
    #[inline]
    pub(crate) fn cell_of(&self, q: &Point2<f64>) -> [i32; 2] {
        let inv_res = 1.0 / self.resolution_m;
        let c = |v: f64, o: f64| {
            let f = (v - o) * inv_res;
            // NaN fails the test and goes far away too.
            if (-FAR_CELL..=FAR_CELL).contains(&f) {
                // The floor, without a call to libm's: truncated, less one below zero.
                let t = f as i32;
                t - i32::from(f64::from(t) > f)
            } else {
                FAR_CELL as i32
            }
        };
        [c(q.x, self.origin.x), c(q.y, self.origin.y)]
    }

    /// The quantised value at level `level` of cell `cell` (0 outside the grid).
    #[inline]
    pub(crate) fn value(&self, level: u32, cell: [i32; 2]) -> u8 {
        self.levels[level as usize].value(cell)
    }

    /// The sum over `cells`, each shifted by `offset` and weighted by `weights`, at level
    /// `level`.
    #[cfg(test)]
    pub(crate) fn sum(
        &self,
        level: u32,
        cells: &[[i32; 2]],
        weights: &[u32],
        offset: [i32; 2],
    ) -> u64 {
        self.levels[level as usize].sum(cells, weights, offset)
    }

    /// Like [`Self::sum`], but `None` when the sum does not exceed `floor`, given up as soon as
    /// the cells left cannot lift it above `floor`: `headroom[k]` is the most that the cells
    /// of chunks `k..` ([`CHUNK`] cells each) can add. Writes each chunk's sum to `chunk_sums`
    /// (whole only when the answer is `Some`) and adds the cells read to `read`.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn sum_above(
        &self,
        level: u32,
        cells: &[[i32; 2]],
        weights: &[u32],
        headroom: &[u64],
        offset: [i32; 2],
        floor: u64,
        read: &mut u64,
        chunk_sums: &mut [u64],
    ) -> Option<u64> {
        let lv = &self.levels[level as usize];
        let mut sum = 0;
        let chunks = cells.chunks(CHUNK).zip(weights.chunks(CHUNK));
        for ((c, w), (&room, out)) in chunks.zip(headroom.iter().zip(chunk_sums)) {
            if sum + room <= floor {
                return None;
            }
            *read += c.len() as u64;
            *out = lv.sum(c, w, offset);
            sum += *out;
        }
        (sum > floor).then_some(sum)
    }
}

/// Fills `headroom` with the suffix sums of `chunk_sums` (`headroom[k]`: chunks `k..`), the
/// headroom of [`LikelihoodGrid::sum_above`].
pub(crate) fn suffix_sums(chunk_sums: &[u64], headroom: &mut [u64]) {
    let mut rest = 0;
    for (h, &c) in headroom.iter_mut().zip(chunk_sums).rev() {
        rest += c;
        *h = rest;
    }
}

/// Cells read between two checks of a sum against its floor.
pub(crate) const CHUNK: usize = 16;

/// Weight units per metre of range.
const WEIGHT_PER_M: f64 = 64.0;

/// The largest weight: a sum over 2^24 returns cannot overflow.
const MAX_WEIGHT: f64 = (1u32 << 24) as f64;

/// The weight of a source return in the score: its range, in 1/64 m (at least 1; see the
/// score in [`crate::global`]).
pub(crate) fn range_weight(r: &Return) -> u32 {
    (r.range_m * WEIGHT_PER_M).round().clamp(1.0, MAX_WEIGHT) as u32
}

/// A weighted sum of quantised values as a weighted mean likelihood in [0, 1], given the sum
/// of the weights (0 without weights).
pub(crate) fn mean_of(sum: u64, total: u64) -> f64 {
    if total == 0 {
        0.0
    } else {
        sum as f64 / (total as f64 * f64::from(FULL_SCALE))
    }
}

/// The score of `t_ref_src` on `grid`: the mean over `source`'s returns, weighted by their
/// ranges (see the score in [`crate::global`]), of the level-0 likelihood at the cell each
/// moved return falls in (0 outside the grid), in [0, 1]; 0 for a scan without returns. The
/// score the global search maximises, so a fine registration's result can be compared with
/// the search's best (up to a return crossing a cell border where the search moved it by
/// whole cells).
pub fn score_at(grid: &LikelihoodGrid, source: &Scan, t_ref_src: &Isometry2<f64>) -> f64 {
    let (sum, total) = source.returns().iter().fold((0, 0), |(sum, total), r| {
        let w = u64::from(range_weight(r));
        let v = u64::from(grid.value(0, grid.cell_of(&(t_ref_src * r.point))));
        (sum + v * w, total + w)
    });
    mean_of(sum, total)
}

#[cfg(test)]
mod tests {
    use super::max_shifted;
    use proptest::prelude::*;

    proptest! {
        /// The pooled array is the definition's, shifts longer than the array included.
        #[test]
        fn max_shifted_is_the_max_of_the_array_and_its_shift(
            v in prop::collection::vec(any::<u8>(), 0..40),
            s in 0usize..50,
        ) {
            let at = |k: isize| usize::try_from(k).ok().and_then(|k| v.get(k)).copied().unwrap_or(0);
            let expected: Vec<u8> = (0..(v.len() + s) as isize)
                .map(|a| at(a).max(at(a - s as isize)))
                .collect();
            let mut out = vec![7];
            max_shifted(&mut out, &v, s);
            prop_assert_eq!(&out[1..], &expected[..]);
        }
    }
}
