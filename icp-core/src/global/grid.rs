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

use super::likelihood::QUANTISED_EXP;
pub use super::likelihood::{FULL_SCALE, TRUNCATION_SIGMAS};
use crate::error::ScanRole;
use crate::scan::Return;
use crate::{IcpError, Scan};

/// Most cells along a side of a level.
const MAX_SIDE_CELLS: f64 = (1 << 26) as f64;

/// Most cells of a level, padding included: a cell's index fits a `u32`.
const MAX_LEVEL_CELLS: f64 = (1u64 << 32) as f64;

/// Cell coordinates are clamped to ±this: far outside any level (see [`MAX_SIDE_CELLS`]) even
/// after a window offset (at most 2^12 cells) and a level's padding (less than 2^15 cells),
/// and far from `i32` overflow.
const FAR_CELL: f64 = (1 << 28) as f64;

/// Writes into `out` the level above `level` (which pools blocks of `s` cells, the result
/// `2s`) in the layout shared by every level (rows of `stride` cells): the cell at index `k`
/// is the max of the cells at `k`, `k + s`, `k + s·stride` and `k + s·stride + s`, in one
/// pass. An index past the end reads 0, and one past a row's end reads the next row's start,
/// which is padding (0) at every level but the top one (see [`LikelihoodGrid::new`]).
fn pool_into(level: &[u8], s: usize, stride: usize, out: &mut Vec<u8>) {
    let n = level.len();
    let ahead = [s, s * stride, s * stride + s];
    let from = |a: usize| &level[a.min(n)..];
    // `k + a < n` for `k` below `n − a`: the cells whose sources from `ahead[m]` on are past
    // the end, and read 0, come last.
    let [one, two, all] = ahead.map(|a| n.saturating_sub(a));
    out.clear();
    out.reserve(n);
    out.extend(
        level[..all]
            .iter()
            .zip(from(ahead[0]))
            .zip(from(ahead[1]))
            .zip(from(ahead[2]))
            .map(|(((&a, &b), &c), &d)| a.max(b).max(c.max(d))),
    );
    out.extend(
        level[all..two]
            .iter()
            .zip(from(all + ahead[0]))
            .zip(from(all + ahead[1]))
            .map(|((&a, &b), &c)| a.max(b).max(c)),
    );
    out.extend(
        level[two..one]
            .iter()
            .zip(from(two + ahead[0]))
            .map(|(&a, &b)| a.max(b)),
    );
    out.extend_from_slice(&level[one..]);
}

/// The cells of likelihood grids' levels, handed from one grid to the next (see
/// [`GlobalMatcher::new_in`](super::GlobalMatcher::new_in) and `recycle`): a run's grids
/// then reuse their memory, where a freshly allocated level costs a page fault per page on
/// first write.
#[derive(Clone, Debug, Default)]
pub struct GridPool {
    levels: Vec<Vec<u8>>,
}

impl GridPool {
    /// A level's storage, empty (with the capacity it had).
    fn take(&mut self) -> Vec<u8> {
        self.levels.pop().unwrap_or_default()
    }
}

/// Where level 0's cells are: `nx × ny` cells of side `resolution_m` from `origin`, cell
/// `(i, j)` at index `(j + pad) · stride + i + pad`.
struct Cells {
    nx: usize,
    ny: usize,
    stride: usize,
    pad: usize,
    origin: Point2<f64>,
    resolution_m: f64,
}

impl Cells {
    /// Writes into `level0` (zeros) the likelihood of `points` with `sigma_m` (see the module
    /// doc). For each point, the cells' squared distances along x are made once, and each
    /// row visits only its run of cells in reach: each cell's arithmetic is the same as one by
    /// one, so are its values.
    fn rasterise(&self, points: &[Point2<f64>], sigma_m: f64, level0: &mut [u8]) {
        let (resolution_m, stride, pad) = (self.resolution_m, self.stride, self.pad);
        let reach_m = TRUNCATION_SIGMAS * sigma_m;
        let inv_two_var = 1.0 / (2.0 * sigma_m * sigma_m);
        let reach_sq = reach_m * reach_m;
        let quantised_exp = &*QUANTISED_EXP;
        // The cells whose centre may be within reach of coordinate c along one axis, and
        // the squared distances of their centres from it.
        let span = |c: f64, n: usize| {
            let first = ((c - reach_m) / resolution_m).floor().max(0.0) as usize;
            let last = ((c + reach_m) / resolution_m).floor().min(n as f64 - 1.0) as usize;
            first..=last
        };
        let squared = |k: usize, c: f64| {
            let d = (k as f64 + 0.5) * resolution_m - c;
            d * d
        };
        let mut dx_sq = Vec::new();
        for p in points {
            let (px, py) = (p.x - self.origin.x, p.y - self.origin.y);
            let columns = span(px, self.nx);
            let first = *columns.start();
            dx_sq.clear();
            dx_sq.extend(columns.map(|i| squared(i, px)));
            for j in span(py, self.ny) {
                let dy_sq = squared(j, py);
                // The cells in reach are a run: the x distances fall then rise.
                let in_reach = |dxx: &f64| dxx + dy_sq <= reach_sq;
                let (Some(lo), Some(hi)) = (
                    dx_sq.iter().position(in_reach),
                    dx_sq.iter().rposition(in_reach),
                ) else {
                    continue;
                };
                let row = &mut level0[(j + pad) * stride + pad + first..][lo..=hi];
                for (cell, &dxx) in row.iter_mut().zip(&dx_sq[lo..=hi]) {
                    quantised_exp.raise(cell, (dxx + dy_sq) * inv_two_var);
                }
            }
        }
    }
}

/// The likelihood grid of one reference scan with its max-pooled pyramid (see the module doc).
///
/// Every level has one layout, padded with 0 so that a source return looked up at any
/// offset of the translation window stays inside it: cell `(i, j)` is at index
/// `(j + pad) · stride + i + pad` of each level, for `i` in `−pad..stride − pad` and `j` in
/// `−pad..rows − pad`, with `pad = 2^(depth + 1) − 1 + 2 · window` (for the level above the
/// top too) and `2 · window + 2^depth` more cells past the far side of level 0. A return is
/// looked up by its index at the window's lowest offset plus the offset's shift (`shift`, see
/// `lookups`): no bounds test per axis. The level above the top, which bounds several
/// rotations at once (see `Search::top_level`), is not stored: a cell of it is the max of four
/// of the top level's (see `sum_above`), read only at a few offsets per group.
#[derive(Clone, Debug, PartialEq)]
pub struct LikelihoodGrid {
    /// Level `h` pools blocks of `2^h` cells; level 0 is the likelihood itself.
    levels: Vec<Vec<u8>>,
    /// Cells along x and y of level 0 that may be non-zero.
    nx: i32,
    ny: i32,
    /// Cells of a row and rows of every level, padding included.
    stride: usize,
    rows: usize,
    /// Padding cells before cell `(0, 0)` along each axis.
    pad: i32,
    /// Offsets run over `−window..=window` cells on each axis.
    window: i32,
    /// The lower-left corner of cell `(0, 0)`, reference frame, metres.
    origin: Point2<f64>,
    resolution_m: f64,
    /// `1 / resolution_m`, cells per metre.
    cells_per_m: f64,
    sigma_m: f64,
}

impl LikelihoodGrid {
    /// The grid of `reference`'s points with cells of `resolution_m`, the likelihood's
    /// `sigma_m`, `depth` max-pooled levels above level 0, padded for offsets of up to
    /// `window` cells (parameters assumed valid: see [`super::GlobalParams::validate`]).
    ///
    /// The levels' storage is taken from `pool` (see [`Self::recycle`]): what it held before
    /// does not matter.
    ///
    /// `Err(TooFewPoints)` for a scan without returns, `Err(GlobalSearchTooLarge)` when the levels
    /// together, padding included, would hold more than `max_cells` cells.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        reference: &Scan,
        resolution_m: f64,
        sigma_m: f64,
        depth: u32,
        window: i32,
        max_cells: u64,
        pool: &mut GridPool,
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
        // The level above the top pools 2^(depth + 1) cells, and a return's cell under a group
        // of rotations lies up to 2^depth cells past its lowest one (see `Self::group_keeps`).
        let pad = ((1u64 << (depth + 1)) - 1) as f64 + 2.0 * f64::from(window);
        let padded = |n: f64| n + pad + 2.0 * f64::from(window) + (1u64 << depth) as f64;
        let side = padded(fx.max(fy));
        if side > MAX_SIDE_CELLS {
            return Err(IcpError::GlobalSearchTooLarge {
                what: "grid cells along a side",
                count: side,
                max: MAX_SIDE_CELLS,
            });
        }
        let per_level = padded(fx) * padded(fy);
        if per_level > MAX_LEVEL_CELLS {
            return Err(IcpError::GlobalSearchTooLarge {
                what: "grid cells of a level",
                count: per_level,
                max: MAX_LEVEL_CELLS,
            });
        }
        let total = f64::from(depth + 1) * per_level;
        if total > max_cells as f64 {
            return Err(IcpError::GlobalSearchTooLarge {
                what: "grid cells (max_grid_cells)",
                count: total,
                max: max_cells as f64,
            });
        }
        let (nx, ny) = (fx as usize, fy as usize);
        let (stride, rows, pad) = (padded(fx) as usize, padded(fy) as usize, pad as usize);
        let mut data = pool.take();
        data.clear();
        data.resize(stride * rows, 0);
        let cells = Cells {
            nx,
            ny,
            stride,
            pad,
            origin,
            resolution_m,
        };
        cells.rasterise(&points, sigma_m, &mut data);
        let mut levels = vec![data];
        for h in 1..=depth {
            let mut next = pool.take();
            pool_into(&levels[h as usize - 1], 1 << (h - 1), stride, &mut next);
            levels.push(next);
        }
        Ok(Self {
            levels,
            nx: nx as i32,
            ny: ny as i32,
            stride,
            rows,
            pad: pad as i32,
            window,
            origin,
            resolution_m,
            cells_per_m: 1.0 / resolution_m,
            sigma_m,
        })
    }

    /// Gives the levels' storage to `pool`, for the next grid.
    pub(crate) fn recycle(self, pool: &mut GridPool) {
        pool.levels.extend(self.levels);
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

    /// Offsets either side of a lookup's cell that the padding allows, cells.
    pub(crate) fn window_cells(&self) -> i32 {
        self.window
    }

    /// Cells along x and y of level 0.
    pub fn size(&self) -> (usize, usize) {
        (self.nx as usize, self.ny as usize)
    }

    /// The cell holding `q` (reference frame): integer cell coordinates, clamped far outside
    /// the grid when `q` is far away or not finite.
    #[inline]
    pub(crate) fn cell_of(&self, q: &Point2<f64>) -> [i32; 2] {
        let c = |f: f64| {
            // NaN fails the test and goes far away too.
            if (-FAR_CELL..=FAR_CELL).contains(&f) {
                floor(f)
            } else {
                FAR_CELL as i32
            }
        };
        cell_coordinates(q, self.origin, self.cells_per_m).map(c)
    }

    /// The lookup of a return at `q` (reference frame) with `weight`, for a `q` whose cell is
    /// known to be one [`Self::lookup_at`] takes (e.g. in a group's box: see
    /// `Search::group_lookups`): its cell is [`Self::cell_of`]'s, without the clamp.
    #[inline]
    pub(crate) fn lookup_in_reach(&self, q: &Point2<f64>, weight: u32) -> Lookup {
        let [fx, fy] = cell_coordinates(q, self.origin, self.cells_per_m);
        self.lookup_at([floor(fx), floor(fy)], weight)
    }

    /// The quantised value at level `level` of cell `cell` (0 outside the grid).
    #[inline]
    pub(crate) fn value(&self, level: u32, [i, j]: [i32; 2]) -> u8 {
        // A negative index wraps to a large u32 and fails the test: one compare per axis.
        let (a, b) = (
            (i + self.pad) as u32 as usize,
            (j + self.pad) as u32 as usize,
        );
        if a < self.stride && b < self.rows {
            self.levels[level as usize][b * self.stride + a]
        } else {
            0
        }
    }

    /// Appends to `out` the lookups of `returns` (reference frame, with their weights) that
    /// may add to a sum, in their order: a return's lookup is its cell's ([`Self::cell_of`])
    /// index at the window's lowest offset; it is left out when its cell lies so far outside
    /// that no offset of the window brings it onto a cell of any level that may be non-zero
    /// (level `h`'s cells `i` in `1 − 2^h..nx`, likewise `j`), adding 0 to every sum.
    pub(crate) fn lookups(
        &self,
        returns: impl ExactSizeIterator<Item = (Point2<f64>, u32)>,
        out: &mut Vec<Lookup>,
    ) {
        let w = self.window;
        let top = (1 << self.depth()) - 1;
        // A cell `floor(f)` in `−top − w..n + w` is an `f` in `[−top − w, n + w)`, and NaN is
        // in none; then `c − w + pad ≥ 0` and `c + w + pad < stride` (or `rows`).
        let low = f64::from(-top - w);
        let (high_x, high_y) = (f64::from(self.nx + w), f64::from(self.ny + w));
        let (origin, inv_res) = (self.origin, self.cells_per_m);
        out.reserve(returns.len());
        for (q, weight) in returns {
            let [fx, fy] = cell_coordinates(&q, origin, inv_res);
            if (low..high_x).contains(&fx) && (low..high_y).contains(&fy) {
                out.push(self.lookup_at([floor(fx), floor(fy)], weight));
            }
        }
    }

    /// What offset `offset` (in `−window..=window` on each axis) adds to a [`Lookup`]'s index.
    #[inline]
    pub(crate) fn shift(&self, [dx, dy]: [i32; 2]) -> usize {
        let w = self.window;
        debug_assert!(
            dx.abs() <= w && dy.abs() <= w,
            "offset {dx}, {dy} outside ±{w}"
        );
        (dy + w) as usize * self.stride + (dx + w) as usize
    }

    /// The sum over `cells`, each shifted by `offset` and weighted by `weights`, at level
    /// `level`, cell by cell: the definition that the lookups' sums equal.
    #[cfg(test)]
    pub(crate) fn sum(
        &self,
        level: u32,
        cells: &[[i32; 2]],
        weights: &[u32],
        [dx, dy]: [i32; 2],
    ) -> u64 {
        cells
            .iter()
            .zip(weights)
            .map(|(&[i, j], &w)| u64::from(self.value(level, [i + dx, j + dy])) * u64::from(w))
            .sum()
    }

    /// The weighted sum at level `level` of `lookups` moved by the offset of `shift` (see
    /// [`Self::shift`]), or `None` when it does not exceed `floor`, given up as soon as the
    /// lookups left cannot lift it above `floor`: `headroom[k]` is the most that the lookups
    /// of chunks `k..` ([`CHUNK`] each) can add. Writes each chunk's sum to `chunk_sums`
    /// (whole only when the answer is `Some`) and adds the cells read to `read`.
    ///
    /// `level` may be the one above the top (`depth + 1`), for the lookups of a group of
    /// rotations ([`Self::group_keeps`]): it is not stored, its cell `k` is the max of the top
    /// level's four at `k`, `k + s`, `k + s · stride` and `k + s · stride + s` (`s =
    /// 2^depth`), which stay inside the layout (its far padding is `2^depth` wider than the
    /// window needs).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn sum_above(
        &self,
        level: u32,
        lookups: &[Lookup],
        headroom: &[u64],
        shift: usize,
        floor: u64,
        read: &mut u64,
        chunk_sums: &mut [u64],
    ) -> Option<u64> {
        let top = self.depth();
        // Every lookup's index plus the shift is inside the level (see `Self::lookups`).
        let cells = &self.levels[level.min(top) as usize][shift..];
        if level <= top {
            let value = |index: usize| cells[index];
            return sum_above_with(lookups, headroom, floor, read, chunk_sums, value);
        }
        let s = 1usize << top;
        let ahead = [s, s * self.stride, s * self.stride + s];
        let value = |index: usize| {
            let block = &cells[index..=index + ahead[2]];
            block[0]
                .max(block[ahead[0]])
                .max(block[ahead[1]].max(block[ahead[2]]))
        };
        sum_above_with(lookups, headroom, floor, read, chunk_sums, value)
    }
}

/// The sum of [`LikelihoodGrid::sum_above`] with the cells' values by `value` (of a lookup's
/// index).
#[inline]
fn sum_above_with(
    lookups: &[Lookup],
    headroom: &[u64],
    floor: u64,
    read: &mut u64,
    chunk_sums: &mut [u64],
    value: impl Fn(usize) -> u8,
) -> Option<u64> {
    let mut sum = 0;
    let chunks = lookups.chunks(CHUNK).zip(headroom.iter().zip(chunk_sums));
    for (chunk, (&room, out)) in chunks {
        if sum + room <= floor {
            return None;
        }
        *read += chunk.len() as u64;
        let weighted = |l: &Lookup| u64::from(value(l.index as usize)) * u64::from(l.weight);
        // A whole chunk has a fixed length: its loop is unrolled.
        *out = match <&[Lookup; CHUNK]>::try_from(chunk) {
            Ok(whole) => whole.iter().map(weighted).sum(),
            Err(_) => chunk.iter().map(weighted).sum(),
        };
        sum += *out;
    }
    (sum > floor).then_some(sum)
}

impl LikelihoodGrid {
    /// True when a return whose lowest cell under a group of rotations is `lo` may add to a
    /// sum of the level above the top, or to one of the top level's under a rotation of the
    /// group (its cell there in `lo..=lo + 2^depth`): `lo` in `−(2^(depth+1) − 1) − w..n + w`,
    /// the cells of that level that may be non-zero less the window's offsets. Then the
    /// lookups [`Self::lookup_at`] makes of `lo` and of every such cell stay inside the levels.
    pub(crate) fn group_keeps(&self, lo: [i32; 2]) -> bool {
        let w = self.window;
        let low = 1 - (2 << self.depth()) - w;
        (low..self.nx + w).contains(&lo[0]) && (low..self.ny + w).contains(&lo[1])
    }

    /// The lookup of a return at `cell` with `weight`, for a cell that [`Self::lookups`]
    /// keeps or that is `lo..=lo + 2^depth` for an `lo` that [`Self::group_keeps`].
    #[inline]
    pub(crate) fn lookup_at(&self, [i, j]: [i32; 2], weight: u32) -> Lookup {
        let shift = self.pad - self.window;
        let (a, b) = ((i + shift) as usize, (j + shift) as usize);
        Lookup {
            index: (b * self.stride + a) as u32,
            weight,
        }
    }
}

/// A source return ready for the sums of one rotation: see [`LikelihoodGrid::lookups`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Lookup {
    /// Its cell's index in every level at the window's lowest offset.
    index: u32,
    /// Its weight in the score.
    pub weight: u32,
}

/// Replaces each of `values` by the sum of it and those after it: from chunk sums, the
/// headroom of [`LikelihoodGrid::sum_above`] (`headroom[k]`: chunks `k..`).
pub(crate) fn suffix_sums(values: &mut [u64]) {
    let mut rest = 0;
    for v in values.iter_mut().rev() {
        rest += *v;
        *v = rest;
    }
}

/// Cells read between two checks of a sum against its floor.
pub(crate) const CHUNK: usize = 16;

/// `q`'s coordinates in cells of side `1 / inv_res` from `origin`, whose floors are its cell.
#[inline]
fn cell_coordinates(q: &Point2<f64>, origin: Point2<f64>, inv_res: f64) -> [f64; 2] {
    [(q.x - origin.x) * inv_res, (q.y - origin.y) * inv_res]
}

/// The floor of `f` (within `i32`'s range), without a call to libm's: truncated, less one
/// below zero.
#[inline]
fn floor(f: f64) -> i32 {
    let t = f as i32;
    t - i32::from(f64::from(t) > f)
}

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
    use super::{pool_into, GridPool, LikelihoodGrid};
    use crate::Scan;
    use nalgebra::Vector2;
    use proptest::prelude::*;

    proptest! {
        /// The pooled array is the definition's (an index past the end reads 0), shifts
        /// longer than the array included, whatever the output held before.
        #[test]
        fn pooling_is_the_max_of_the_four_cells_ahead(
            v in prop::collection::vec(any::<u8>(), 0..60),
            s in 0usize..12,
            stride in 1usize..12,
            held in prop::collection::vec(any::<u8>(), 0..80),
        ) {
            let at = |k: usize| v.get(k).copied().unwrap_or(0);
            let expected: Vec<u8> = (0..v.len())
                .map(|k| at(k).max(at(k + s)).max(at(k + s * stride)).max(at(k + s * stride + s)))
                .collect();
            let mut out = held;
            pool_into(&v, s, stride, &mut out);
            prop_assert_eq!(out, expected);
        }

        /// Every cell of every level, padding included, is the max of level 0's cells in its
        /// block (0 outside level 0's `nx × ny`); a return's lookup reads that value at every
        /// offset of the window, and a return without a lookup reads 0 at every level and
        /// offset; a group's lookup reads the level above the top's value, down to the
        /// lowest and up to the highest cell a group keeps.
        #[test]
        fn levels_and_lookups_are_the_definition(
            reference in prop::collection::vec((-1.0..1.0f64, -1.0..1.0f64), 1..20),
            depth in 0u32..5,
            window in 0i32..6,
            resolution_m in 0.1..0.4f64,
            cells in prop::collection::vec((-40i32..40, -40i32..40), 1..10),
            other_extent_m in 0.0..4.0f64,
        ) {
            let pts: Vec<[f64; 2]> = reference.iter().map(|&(x, y)| [x, y]).collect();
            let scan = Scan::from_cartesian(&pts).unwrap();
            // Levels made in storage that held another grid's, larger or smaller.
            let mut pool = GridPool::default();
            let other = Scan::from_cartesian(&[[0.0, 0.0], [other_extent_m, 1.0]]).unwrap();
            LikelihoodGrid::new(&other, 0.1, 0.1, depth + 1, 3, u64::MAX, &mut pool)
                .unwrap()
                .recycle(&mut pool);
            let grid = LikelihoodGrid::new(&scan, resolution_m, 0.1, depth, window, u64::MAX, &mut pool)
                .unwrap();
            let (nx, ny) = (grid.nx, grid.ny);
            let level0 = |i: i32, j: i32| {
                if (0..nx).contains(&i) && (0..ny).contains(&j) {
                    grid.value(0, [i, j])
                } else {
                    0
                }
            };
            let pad = grid.pad;
            for h in 0..=depth {
                let block = 1 << h;
                for j in -pad..grid.rows as i32 - pad {
                    for i in -pad..grid.stride as i32 - pad {
                        let expected = (0..block)
                            .flat_map(|b| (0..block).map(move |a| (a, b)))
                            .map(|(a, b)| level0(i + a, j + b))
                            .max()
                            .unwrap();
                        prop_assert_eq!(grid.value(h, [i, j]), expected, "level {} cell {} {}", h, i, j);
                    }
                }
            }
            for &(i, j) in &cells {
                let q = grid.origin + Vector2::new(f64::from(i) + 0.5, f64::from(j) + 0.5) * grid.resolution_m;
                prop_assert_eq!(grid.cell_of(&q), [i, j]);
                let mut lookups = Vec::new();
                grid.lookups(std::iter::once((q, 3)), &mut lookups);
                let lookup = lookups.first().copied();
                for h in 0..=depth {
                    for dy in -window..=window {
                        for dx in -window..=window {
                            let expected = 3 * u64::from(grid.value(h, [i + dx, j + dy]));
                            let shift = grid.shift([dx, dy]);
                            let mut chunk = [0];
                            let sum = lookup.map_or(0, |l| {
                                grid.sum_above(h, &[l], &[u64::MAX], shift, 0, &mut 0, &mut chunk)
                                    .unwrap_or(0)
                            });
                            prop_assert_eq!(sum, expected, "level {} cell {} {} offset {} {}", h, i, j, dx, dy);
                        }
                    }
                }
            }
            // The level above the top, for the lowest cells a group of rotations keeps: the max
            // of level 0 over the block of 2^(depth + 1) cells at every offset of the window.
            let above = 2 << depth;
            for (i, j) in cells.iter().copied().chain([(-pad, -pad), (nx + window - 1, ny + window - 1)]) {
                if !grid.group_keeps([i, j]) {
                    continue;
                }
                let lookup = grid.lookup_at([i, j], 3);
                for dy in -window..=window {
                    for dx in -window..=window {
                        let expected = (0..above)
                            .flat_map(|b| (0..above).map(move |a| (a, b)))
                            .map(|(a, b)| 3 * u64::from(level0(i + dx + a, j + dy + b)))
                            .max()
                            .unwrap();
                        let shift = grid.shift([dx, dy]);
                        let sum = grid
                            .sum_above(depth + 1, &[lookup], &[u64::MAX], shift, 0, &mut 0, &mut [0])
                            .unwrap_or(0);
                        prop_assert_eq!(sum, expected, "above the top, cell {} {} offset {} {}", i, j, dx, dy);
                    }
                }
            }
        }
    }
}
