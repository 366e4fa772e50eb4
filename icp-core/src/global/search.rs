//! Depth-first branch-and-bound over the translations of every rotation candidate (Hess et al.
//! 2016, "Real-time loop closure in 2D LIDAR SLAM", ICRA, Algorithm 3).
//!
//! A node is a rotation, a pyramid level `h` and a block of `2^h × 2^h` integer cell offsets
//! (clipped to the window); its score, the source's sum over level `h` of the
//! [`LikelihoodGrid`], bounds the level-0 sum of every offset in the block. The top-level nodes
//! of all rotations are scored first and visited best first; a node is split into its (up to)
//! four children at the level below, visited best first, and dropped as soon as its bound is
//! no better than the best leaf found so far. The result is the exact maximum of the level-0
//! sum over the discrete search space (rotations × offsets), the first one found when several
//! tie.
//!
//! Above a floor (a check's bar), the top-level nodes of neighbouring rotations are first
//! bounded together, one pooled level above the top over a group of rotations along which no
//! return moves by more than a top-level block ([`Search::top_level`]): the nodes kept are
//! the same, only the ones no rotation of a group can lift above the floor are not scored.

use nalgebra::{Point2, UnitComplex, Vector2};

use super::grid::{suffix_sums, LikelihoodGrid, Lookup, CHUNK, FULL_SCALE};

/// Relative room on a group's box: far above a position's rounding (about 1e-16 relative).
const ROUNDING_ROOM: f64 = 1e-9;

/// Fills `headroom` with the most the chunks of `lookups` from each on can add: their
/// weights at full scale.
fn full_scale_headroom(lookups: &[Lookup], headroom: &mut Vec<u64>) {
    headroom.clear();
    headroom.extend(lookups.chunks(CHUNK).map(|chunk| {
        let weight: u64 = chunk.iter().map(|l| u64::from(l.weight)).sum();
        weight * u64::from(FULL_SCALE)
    }));
    suffix_sums(headroom);
}

/// A node of the search: a rotation candidate, a level and the block of offsets it covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Node {
    /// Index in the rotation candidates.
    rotation: u32,
    /// Pyramid level: the block is `2^level` offsets a side.
    level: u32,
    /// The block's lowest offset, cells.
    offset: [i32; 2],
    /// The source's sum over `level` at `offset`: the bound of the block.
    sum: u64,
    /// Where its chunk sums are kept: the index in the top-level nodes' (a top-level node) or
    /// among its parent's children (0..4, the others).
    slot: u32,
}

/// The best pose of a search.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Best {
    /// Index of its rotation candidate (`None`: no pose scores above 0).
    pub rotation: Option<usize>,
    /// Its offset from the centre, cells.
    pub offset: [i32; 2],
    /// Its level-0 sum.
    pub sum: u64,
    /// Cells read.
    pub lookups: u64,
}

/// Reused buffers of the search.
#[derive(Clone, Debug, Default)]
pub(crate) struct Buffers {
    /// The lookups of every rotation's returns (those that may add to a sum), rotation
    /// `r`'s at `starts[r]..starts[r + 1]`, made by [`Search::top_level`] for the descents.
    lookups: Vec<Lookup>,
    starts: Vec<usize>,
    /// The headroom of a top-level node: per chunk of lookups, the rest at full scale.
    headroom: Vec<u64>,
    /// The source points' distances from the sensor, metres.
    norms: Vec<f64>,
    /// A group of rotations' lookups, of the returns it keeps (see
    /// [`Search::group_lookups`]).
    group: Vec<Lookup>,
    kept: Vec<(Point2<f64>, u32)>,
    /// The group's chunk sums, `chunks` per block.
    group_chunks: Vec<u64>,
    /// The top-level blocks, and those a group may lift above the floor.
    blocks: Vec<[i32; 2]>,
    passed: Vec<usize>,
    top: Vec<Node>,
    /// The chunk sums of the top-level nodes, `chunks` per node in the order scored.
    top_chunks: Vec<u64>,
    /// The chunk sums of the children of the last node expanded at each level: level `l`'s
    /// child `s` at `((l − 1) · 4 + s) · chunks`.
    child_chunks: Vec<u64>,
    /// The headroom of the children of the node being expanded: its chunk sums' suffixes.
    parent_room: Vec<u64>,
    stack: Vec<Node>,
    children: Vec<Node>,
}

/// One search: the grid, the source points, the rotation candidates and the window.
pub(crate) struct Search<'a> {
    /// The reference's grid.
    pub grid: &'a LikelihoodGrid,
    /// The source's points.
    pub points: &'a [Point2<f64>],
    /// Their weights.
    pub weights: &'a [u32],
    /// The rotation candidates, radians (absolute: source to reference).
    pub rotations: &'a [f64],
    /// The window's centre translation, metres.
    pub centre: Vector2<f64>,
    /// Offsets run over `−window..=window` cells on each axis.
    pub window: i32,
}

impl Search<'_> {
    /// The source points rotated by candidate `rotation` and moved to the centre.
    fn moved(&self, rotation: usize) -> impl ExactSizeIterator<Item = Point2<f64>> + '_ {
        let r = UnitComplex::new(self.rotations[rotation]);
        self.points.iter().map(move |p| r * p + self.centre)
    }

    /// Appends to `lookups` those of the returns at candidate `rotation` that may add to a
    /// sum (see [`LikelihoodGrid::lookups`]), in the order of the points.
    fn lookups(&self, rotation: usize, lookups: &mut Vec<Lookup>) {
        let returns = self.moved(rotation).zip(self.weights.iter().copied());
        self.grid.lookups(returns, lookups);
    }

    /// Rotation `rotation`'s lookups in `buffers` (made by [`Self::top_level`]).
    fn of_rotation<'b>(lookups: &'b [Lookup], starts: &[usize], rotation: usize) -> &'b [Lookup] {
        &lookups[starts[rotation]..starts[rotation + 1]]
    }

    /// The offsets of the level-`level` blocks starting at `origin` that lie in the window,
    /// stepping `2^level` along each axis up to `last` (inclusive).
    fn blocks(
        &self,
        origin: [i32; 2],
        level: u32,
        last: [i32; 2],
    ) -> impl Iterator<Item = [i32; 2]> {
        let step = 1usize << level;
        let w = self.window;
        (origin[1]..=last[1].min(w))
            .step_by(step)
            .flat_map(move |y| {
                (origin[0]..=last[0].min(w))
                    .step_by(step)
                    .map(move |x| [x, y])
            })
    }

    /// Scores the top-level nodes of every rotation whose bounds exceed `floor` into
    /// `buffers`, sorted best first, and the headroom of the sums, that [`Self::above`] and
    /// [`Self::runner_up`] start from (with a floor no lower); returns the cells read.
    ///
    /// Above a floor, neighbouring rotations are bounded together first: over a group of
    /// rotations along which no return moves by more than a top-level block, each return's
    /// cells lie in a block of that size from its lowest one ([`Self::group_lookups`]), so the
    /// level above the top, read there, bounds the return's top-level value under every
    /// rotation of the group. A block none of them can lift above the floor is not scored
    /// rotation by rotation; the others are, with the group's chunk sums as headroom. The
    /// nodes are the same, with the same sums, in the same order, as scored one rotation at a
    /// time (their chunks may differ: a group's rotations look up the returns the group
    /// keeps).
    pub fn top_level(&self, buffers: &mut Buffers, floor: u64) -> u64 {
        let grid = self.grid;
        let top_level = grid.depth();
        let chunks = self.weights.len().div_ceil(CHUNK);
        let Buffers {
            lookups,
            starts,
            headroom,
            top,
            top_chunks,
            norms,
            group,
            kept,
            group_chunks,
            blocks,
            passed,
            ..
        } = buffers;
        lookups.clear();
        starts.clear();
        starts.push(0);
        top.clear();
        top_chunks.clear();
        let w = self.window;
        blocks.clear();
        blocks.extend(self.blocks([-w, -w], top_level, [w, w]));
        group_chunks.resize(blocks.len() * chunks, 0);
        norms.clear();
        norms.extend(self.points.iter().map(|p| p.coords.norm()));
        let span_rad = self.group_span_rad(norms);
        let mut read = 0;
        // Scores rotation `r`'s block `offset` (its lookups `mine`) against `room`.
        let mut score =
            |r: usize, offset: [i32; 2], mine: &[Lookup], room: &[u64], read: &mut u64| {
                let slot = top.len();
                top_chunks.resize((slot + 1) * chunks, 0);
                let above = grid.sum_above(
                    top_level,
                    mine,
                    room,
                    grid.shift(offset),
                    floor,
                    read,
                    &mut top_chunks[slot * chunks..],
                );
                if let Some(sum) = above {
                    top.push(Node {
                        rotation: r as u32,
                        level: top_level,
                        offset,
                        sum,
                        slot: slot as u32,
                    });
                }
            };
        let mut first = 0;
        while first < self.rotations.len() {
            // A group: rotations in increasing order within the span (so that every one of
            // them lies between the first and the last).
            let mut last = first;
            while floor > 0
                && last + 1 < self.rotations.len()
                && self.rotations[last + 1] >= self.rotations[last]
                && self.rotations[last + 1] - self.rotations[first] <= span_rad
            {
                last += 1;
            }
            if last > first && self.group_lookups(first, last, norms, group, kept) {
                full_scale_headroom(group, headroom);
                passed.clear();
                for (b, &offset) in blocks.iter().enumerate() {
                    let above = grid.sum_above(
                        top_level + 1,
                        group,
                        headroom,
                        grid.shift(offset),
                        floor,
                        &mut read,
                        &mut group_chunks[b * chunks..][..chunks],
                    );
                    if above.is_some() {
                        passed.push(b);
                    }
                }
                // A passing block's chunk sums become its members' headroom, once.
                let used = group.len().div_ceil(CHUNK);
                for &b in passed.iter() {
                    suffix_sums(&mut group_chunks[b * chunks..][..used]);
                }
                for r in first..=last {
                    if !passed.is_empty() {
                        // The returns the group keeps, at their cells under rotation r.
                        let turn = UnitComplex::new(self.rotations[r]);
                        lookups.extend(kept.iter().map(|&(p, weight)| {
                            grid.lookup_in_reach(&(turn * p + self.centre), weight)
                        }));
                    }
                    starts.push(lookups.len());
                    let mine = Self::of_rotation(lookups, starts, r);
                    for &b in passed.iter() {
                        let room = &group_chunks[b * chunks..][..used];
                        score(r, blocks[b], mine, room, &mut read);
                    }
                }
            } else {
                for r in first..=last {
                    self.lookups(r, lookups);
                    starts.push(lookups.len());
                    let mine = Self::of_rotation(lookups, starts, r);
                    full_scale_headroom(mine, headroom);
                    for &offset in blocks.iter() {
                        score(r, offset, mine, headroom, &mut read);
                    }
                }
            }
            first = last + 1;
        }
        top_chunks.truncate(top.len() * chunks);
        // Best first, then in the order of the rotations and of the blocks (y, then x): the
        // order of a stable sort of the nodes made rotation by rotation.
        top.sort_unstable_by_key(|node| {
            (
                std::cmp::Reverse(node.sum),
                node.rotation,
                node.offset[1],
                node.offset[0],
            )
        });
        read
    }

    /// The widest span of rotations bounded together: along it the farthest return moves by
    /// at most a top-level block less two cells (a cell either side for the arc and the
    /// rounding) and bulges off its chord by at most a quarter cell. A group's bound holds
    /// whatever the span (see [`Self::group_lookups`]); only its tightness depends on it.
    fn group_span_rad(&self, norms: &[f64]) -> f64 {
        let reach_m = norms.iter().fold(0.0f64, |m, &n| m.max(n));
        let res = self.grid.resolution_m();
        let block_cells = f64::from(1u32 << self.grid.depth());
        if reach_m > 0.0 {
            let along = (block_cells - 2.0).max(0.0) * res / reach_m;
            let bulge = 2.0 * (1.0 - (0.25 * res / reach_m).min(1.0)).acos();
            along.min(bulge)
        } else {
            0.0
        }
    }

    /// The lookups of a group of rotations, candidates `first` to `last`: each return at its
    /// lowest cell under them, those the grid keeps (their points and weights in `kept`);
    /// `false` (no group) when a return's cells under them may span more than a top-level
    /// block. `norms`: the points' distances from the sensor.
    ///
    /// A return turning between two angles stays within the sagitta `|p| (1 − cos(Δ/2))` of
    /// the chord between its two ends, so within their bounding box widened by that (and by
    /// far more than any rounding of positions no farther than `|p| + |centre|`); a cell is
    /// the floor of a position, monotone, so the return's cell under each rotation of the
    /// group lies between the box's corners' cells.
    fn group_lookups(
        &self,
        first: usize,
        last: usize,
        norms: &[f64],
        group: &mut Vec<Lookup>,
        kept: &mut Vec<(Point2<f64>, u32)>,
    ) -> bool {
        let grid = self.grid;
        let (a0, a1) = (self.rotations[first], self.rotations[last]);
        let (r0, r1) = (UnitComplex::new(a0), UnitComplex::new(a1));
        let sagitta_per_m = 1.0 - (0.5 * (a1 - a0)).cos();
        let block_cells = 1i32 << grid.depth();
        let centre_m = self.centre.norm();
        group.clear();
        kept.clear();
        for ((p, &weight), &norm) in self.points.iter().zip(self.weights).zip(norms) {
            let (q0, q1) = (r0 * p + self.centre, r1 * p + self.centre);
            let room_m = norm * sagitta_per_m + ROUNDING_ROOM * (1.0 + norm + centre_m);
            let low = Point2::new(q0.x.min(q1.x) - room_m, q0.y.min(q1.y) - room_m);
            let high = Point2::new(q0.x.max(q1.x) + room_m, q0.y.max(q1.y) + room_m);
            let (cl, ch) = (grid.cell_of(&low), grid.cell_of(&high));
            if !(0..2).all(|a| (0..=block_cells).contains(&(ch[a] - cl[a]))) {
                return false;
            }
            if grid.group_keeps(cl) {
                group.push(grid.lookup_at(cl, weight));
                kept.push((*p, weight));
            }
        }
        true
    }

    /// The best pose whose sum exceeds `floor` (otherwise `rotation: None`, `sum: floor`),
    /// from the top-level nodes [`Self::top_level`] left in `buffers`. When one exists it is
    /// the pose [`Self::run`] finds: every node above the maximum is visited in the same
    /// order (roots and children sorted stably by their bounds), pruned only once a leaf of
    /// the maximum is found, so the first such leaf is kept either way.
    pub fn above(&self, buffers: &mut Buffers, floor: u64) -> Best {
        self.descend(buffers, floor, None)
    }

    /// The best pose at `best`'s rotation more than `separation` cells of offset away from
    /// it along an axis (`best`: the result of [`Self::run`] on the same buffers), when its sum
    /// exceeds `floor` (otherwise `rotation: None`, `sum: floor`).
    pub fn runner_up(
        &self,
        buffers: &mut Buffers,
        best: &Best,
        floor: u64,
        separation: i32,
    ) -> Best {
        let none = Best {
            rotation: None,
            sum: floor,
            lookups: 0,
            ..*best
        };
        let Some(rotation) = best.rotation else {
            return none;
        };
        let exclusion = Exclusion {
            rotation: rotation as u32,
            lo: best.offset.map(|d| d - separation),
            hi: best.offset.map(|d| d + separation),
            window: self.window,
        };
        self.descend(buffers, floor, Some(&exclusion))
    }

    /// The depth-first descent from the sorted top-level nodes in `buffers`: the best leaf
    /// whose sum exceeds `floor`; with an exclusion, only among the nodes of its rotation and
    /// outside its offsets.
    fn descend(&self, buffers: &mut Buffers, floor: u64, exclusion: Option<&Exclusion>) -> Best {
        let Buffers {
            lookups,
            starts,
            top,
            top_chunks,
            child_chunks,
            parent_room,
            stack,
            children,
            ..
        } = buffers;
        let grid = self.grid;
        let chunks = self.weights.len().div_ceil(CHUNK);
        child_chunks.resize(grid.depth() as usize * 4 * chunks, 0);
        let excluded = |node: &Node| exclusion.is_some_and(|e| e.covers(node));
        let elsewhere = |node: &Node| exclusion.is_some_and(|e| e.rotation != node.rotation);
        let mut best = Best {
            rotation: None,
            offset: [0, 0],
            sum: floor,
            lookups: 0,
        };
        for root in top.iter() {
            if root.sum <= best.sum {
                break; // sorted: no later root can do better
            }
            if elsewhere(root) {
                continue;
            }
            let mine = Self::of_rotation(lookups, starts, root.rotation as usize);
            let used = mine.len().div_ceil(CHUNK);
            stack.clear();
            stack.push(*root);
            while let Some(node) = stack.pop() {
                if node.sum <= best.sum || excluded(&node) {
                    continue;
                }
                if node.level == 0 {
                    best.rotation = Some(node.rotation as usize);
                    best.offset = node.offset;
                    best.sum = node.sum;
                    continue;
                }
                let level = node.level - 1;
                // A child's value at each point is at most the node's (the level above pools
                // the child's and its siblings' cells): the node's chunk sums bound the
                // child's, a headroom much tighter than full scale.
                let own = |l: u32, slot: u32| (l as usize * 4 + slot as usize) * chunks;
                let parent = if node.level == grid.depth() {
                    &top_chunks[node.slot as usize * chunks..][..used]
                } else {
                    &child_chunks[own(node.level, node.slot)..][..used]
                };
                parent_room.clear();
                parent_room.extend_from_slice(parent);
                suffix_sums(parent_room);
                let half = 1i32 << level;
                let last = [node.offset[0] + half, node.offset[1] + half];
                children.clear();
                for (slot, offset) in (0..).zip(self.blocks(node.offset, level, last)) {
                    let above = grid.sum_above(
                        level,
                        mine,
                        parent_room,
                        grid.shift(offset),
                        best.sum,
                        &mut best.lookups,
                        &mut child_chunks[own(level, slot)..][..chunks],
                    );
                    if let Some(sum) = above {
                        children.push(Node {
                            level,
                            offset,
                            sum,
                            slot,
                            ..node
                        });
                    }
                }
                // Best first, ties in generation order (a stable sort), so pushed reversed.
                children.sort_by_key(|node| std::cmp::Reverse(node.sum));
                stack.extend(children.iter().rev());
            }
        }
        best
    }
}

/// The poses near the best one, left out of the search for the runner-up, which looks at the
/// best one's rotation only.
struct Exclusion {
    /// The best one's rotation candidate.
    rotation: u32,
    /// The offsets near the best one's: `lo..=hi` along each axis.
    lo: [i32; 2],
    hi: [i32; 2],
    /// The window's half-width, cells: blocks are clipped to it.
    window: i32,
}

impl Exclusion {
    /// True when every offset of `node` is near the best one's.
    fn covers(&self, node: &Node) -> bool {
        let extent = (1i32 << node.level) - 1;
        (0..2).all(|a| {
            node.offset[a] >= self.lo[a] && (node.offset[a] + extent).min(self.window) <= self.hi[a]
        })
    }
}

#[cfg(test)]
impl Search<'_> {
    /// The best pose by branch and bound (see the module doc): the top level, then the
    /// descent above 0.
    pub fn run(&self, buffers: &mut Buffers) -> Best {
        let top_lookups = self.top_level(buffers, 0);
        let mut best = self.above(buffers, 0);
        best.lookups += top_lookups;
        best
    }

    /// The best pose by scoring every offset of every rotation at level 0: the oracle the
    /// branch and bound must equal.
    pub fn brute_force(&self) -> Best {
        let mut best = Best {
            rotation: None,
            offset: [0, 0],
            sum: 0,
            lookups: 0,
        };
        let w = self.window;
        for rotation in 0..self.rotations.len() {
            let cells: Vec<[i32; 2]> = self
                .moved(rotation)
                .map(|q| self.grid.cell_of(&q))
                .collect();
            for offset in self.blocks([-w, -w], 0, [w, w]) {
                let sum = self.grid.sum(0, &cells, self.weights, offset);
                best.lookups += cells.len() as u64;
                if sum > best.sum {
                    best = Best {
                        rotation: Some(rotation),
                        offset,
                        sum,
                        ..best
                    };
                }
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::global::grid::GridPool;
    use crate::Scan;
    use proptest::prelude::*;

    /// The level-0 sum of one pose of `search`.
    fn sum_at(search: &Search<'_>, rotation: usize, offset: [i32; 2]) -> u64 {
        let cells: Vec<[i32; 2]> = search
            .moved(rotation)
            .map(|q| search.grid.cell_of(&q))
            .collect();
        search.grid.sum(0, &cells, search.weights, offset)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(96))]
        /// On random scenes, windows, pyramid depths (fewer levels than the window needs, as
        /// many, more) and rotations, the branch and bound finds the brute-force maximum, at a
        /// pose of the search space that has it, reading fewer cells when the window is large;
        /// searched above a floor, it finds the same pose when the maximum exceeds the floor.
        #[test]
        fn branch_and_bound_equals_brute_force(
            reference in prop::collection::vec((-3.0..3.0f64, -3.0..3.0f64), 1..60),
            source in prop::collection::vec((-3.0..3.0f64, -3.0..3.0f64, 1u32..3000), 1..40),
            rotations in prop::collection::vec(-3.2..3.2f64, 1..5),
            lattice in prop::option::of((0.001..0.05f64, 2usize..40)),
            window in 0i32..10,
            depth in 0u32..6,
            resolution_m in 0.05..0.3f64,
            sigma_m in 0.02..0.4f64,
            centre in (-0.5..0.5f64, -0.5..0.5f64),
            separation in 0i32..5,
            ratio in 0.0..1.0f64,
            floor_ratio in 0.0..1.2f64,
        ) {
            let pts: Vec<[f64; 2]> = reference.iter().map(|&(x, y)| [x, y]).collect();
            let scan = Scan::from_cartesian(&pts).unwrap();
            let grid =
                LikelihoodGrid::new(&scan, resolution_m, sigma_m, depth, window, u64::MAX, &mut GridPool::default())
                    .unwrap();
            let points: Vec<Point2<f64>> =
                source.iter().map(|&(x, y, _)| Point2::new(x, y)).collect();
            let weights: Vec<u32> = source.iter().map(|&(_, _, w)| w).collect();
            // Random rotations, or a lattice as the candidates are (groups of neighbours).
            let rotations: Vec<f64> = match lattice {
                Some((step, n)) => (0..n).map(|k| rotations[0] + k as f64 * step).collect(),
                None => rotations,
            };
            let search = Search {
                grid: &grid,
                points: &points,
                weights: &weights,
                rotations: &rotations,
                centre: Vector2::new(centre.0, centre.1),
                window,
            };
            let mut buffers = Buffers::default();
            let bnb = search.run(&mut buffers);
            let brute = search.brute_force();
            prop_assert_eq!(bnb.sum, brute.sum);
            match bnb.rotation {
                Some(r) => {
                    prop_assert!(bnb.offset.iter().all(|d| d.abs() <= window));
                    prop_assert_eq!(sum_at(&search, r, bnb.offset), bnb.sum);
                }
                None => prop_assert_eq!(bnb.sum, 0),
            }
            // Above a floor: the same pose when the best exceeds it, none otherwise.
            let floor = (floor_ratio * bnb.sum as f64) as u64;
            let above = search.above(&mut buffers, floor);
            if bnb.sum > floor {
                prop_assert_eq!((above.rotation, above.offset, above.sum), (bnb.rotation, bnb.offset, bnb.sum));
            } else {
                prop_assert_eq!((above.rotation, above.sum), (None, floor));
            }
            // Scored above the floor (neighbouring rotations bounded together): the nodes of
            // the whole top level that exceed it, in the same order, and the same descent.
            let nodes = |buffers: &Buffers| -> Vec<(u32, [i32; 2], u64)> {
                buffers
                    .top
                    .iter()
                    .filter(|n| n.sum > floor)
                    .map(|n| (n.rotation, n.offset, n.sum))
                    .collect()
            };
            search.top_level(&mut buffers, 0);
            let whole = nodes(&buffers);
            search.top_level(&mut buffers, floor);
            prop_assert_eq!(nodes(&buffers), whole);
            prop_assert!(buffers.top.iter().all(|n| n.sum > floor));
            let grouped = search.above(&mut buffers, floor);
            prop_assert_eq!(
                (grouped.rotation, grouped.offset, grouped.sum),
                (above.rotation, above.offset, above.sum)
            );
            // The runner-up at the best rotation, away from the best offset (from the whole
            // top level again).
            search.top_level(&mut buffers, 0);
            let floor = (ratio * bnb.sum as f64) as u64;
            let runner_up = search.runner_up(&mut buffers, &bnb, floor, separation);
            let oracle = bnb.rotation.and_then(|r| {
                search
                    .blocks([-window, -window], 0, [window, window])
                    .filter(|o| (0..2).any(|a| (o[a] - bnb.offset[a]).abs() > separation))
                    .map(|o| sum_at(&search, r, o))
                    .filter(|&s| s > floor)
                    .max()
            });
            prop_assert_eq!(runner_up.rotation.map(|_| runner_up.sum), oracle);
            if let Some(r) = runner_up.rotation {
                prop_assert_eq!(Some(r), bnb.rotation);
                let away = |a: usize| (runner_up.offset[a] - bnb.offset[a]).abs() > separation;
                prop_assert!(away(0) || away(1));
                prop_assert_eq!(sum_at(&search, r, runner_up.offset), runner_up.sum);
            }
        }
    }

    /// Reused buffers give the same result, and the search reads far fewer cells than the
    /// brute force on a window of 41 × 41 offsets.
    #[test]
    fn buffers_are_reusable_and_pruning_pays() {
        let wall = |i: usize| {
            let s = i as f64 * 0.05;
            match i % 3 {
                0 => [4.0, -2.0 + s],
                1 => [-1.0 + s, 3.0],
                _ => [-1.0 + s * 0.5, -2.5 - s * 0.3],
            }
        };
        let pts: Vec<[f64; 2]> = (0..240).map(wall).collect();
        let scan = Scan::from_cartesian(&pts).unwrap();
        let grid = LikelihoodGrid::new(&scan, 0.1, 0.1, 6, 20, u64::MAX, &mut GridPool::default())
            .unwrap();
        let points: Vec<Point2<f64>> = scan
            .returns()
            .iter()
            .map(|r| Point2::new(r.point.x - 0.73, r.point.y + 0.41))
            .collect();
        let weights = vec![1; points.len()];
        let rotations: Vec<f64> = (-10..=10).map(|k| f64::from(k) * 0.01).collect();
        let search = Search {
            grid: &grid,
            points: &points,
            weights: &weights,
            rotations: &rotations,
            centre: Vector2::zeros(),
            window: 20,
        };
        let mut buffers = Buffers::default();
        let first = search.run(&mut buffers);
        assert_eq!(search.run(&mut buffers), first);
        let brute = search.brute_force();
        assert_eq!(first.sum, brute.sum);
        assert_eq!((first.rotation, first.offset), (Some(10), [7, -4]));
        assert!(first.lookups * 20 < brute.lookups, "{first:?} vs {brute:?}");
    }
}
