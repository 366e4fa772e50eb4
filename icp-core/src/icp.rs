//! The ICP loop (Naus & Marchel 2019, Algorithm 1 and eqs. 14, 21, 22) and the
//! [`Registrar`] trait every registration method implements.

use std::any::Any;

use nalgebra::{Isometry2, Matrix3, Point2, SymmetricEigen, Vector2, Vector3};

use crate::error::ScanRole;
use crate::matching::{Correspondence, Grid, Matcher, Matches, NearestIndex};
use crate::minimize::Minimizer;
use crate::robust::RobustKernel;
use crate::scan::{check_geometry, Return, Scan, MIN_POINTS};
use crate::select::Selection;
use crate::termination::{StopReason, Termination};
use crate::weighting::{PairBatch, PairWeighting};
use crate::IcpError;

/// The outcome of one registration of a source scan onto a reference scan.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Registration {
    /// Maps points of the source scan (k) into the reference scan's frame (k+1).
    pub t_ref_src: Isometry2<f64>,
    /// Minimisation steps taken.
    pub iterations: usize,
    /// Why the loop stopped.
    pub stop: StopReason,
    /// Pairs used by the last minimisation step.
    pub n_pairs: usize,
    /// Sum of the final pair weights of the last minimisation step (scheme × robust factor).
    pub weight_sum: f64,
    /// Mean pair distance after the final estimate, metres.
    pub mean_dist_m: f64,
    /// How well the final pairs constrain the motion (`None` with fewer than 3 usable normals).
    pub conditioning: Option<Conditioning>,
    /// How much the scans overlap at the solution: the smaller of the fractions of source
    /// points near reference points and of reference points near source points, "near" being
    /// closer than [`OVERLAP_GATE_M`] (see [`Registration::no_overlap`]).
    pub overlap: f64,
}

/// A final pair closer than this counts as overlap, metres: a few times the pair distances of
/// a converged marina registration (0.11 m on average, from noise and 0.48° beam spacing).
pub const OVERLAP_GATE_M: f64 = 0.5;

/// Below this overlap fraction a registration is flagged as having no overlap: the scans do
/// not see the same surfaces, and the motion that aligns their point clouds means nothing.
/// On the marina data and the synthetic harbour, H/HM/HD_ICP registrations score 0.88 and
/// more; K_ICP's local minima go down to 0.15 and stay above the threshold on purpose: they
/// are wrong registrations of overlapping scans and belong in K_ICP's error statistics.
pub const MIN_OVERLAP: f64 = 0.1;

/// The conditioning of the registration at its solution: the eigenvalues of the Gauss-Newton
/// Hessian `H = Σ J Jᵀ / N` of eq. 14 (unit weights: the geometry of the final pairs)
/// linearised along the reference surface normals (point-to-line), with
/// `J = [n_x, n_y, (p − m) × n / L]`: `n` the reference normal from
/// its scan neighbours, `p` the moved source point, `m` their centroid and `L` their RMS
/// distance from it, so all three directions are in metres. A corridor or a single wall
/// leaves one direction unconstrained (a near-zero eigenvalue); point-to-point ICP still
/// returns a number there, which is why it is flagged rather than trusted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conditioning {
    /// Eigenvalues of H, ascending (dimensionless: mean squared normal components).
    pub eigenvalues: [f64; 3],
    /// Smallest over largest eigenvalue, in [0, 1].
    pub ratio: f64,
}

/// Below this conditioning ratio a registration is flagged as degenerate. A scene with walls
/// in every direction scores ~0.1–0.5; a straight corridor scores below 0.001.
pub const DEGENERATE_RATIO: f64 = 0.01;

impl Conditioning {
    /// True when one motion direction is barely constrained.
    pub fn degenerate(&self) -> bool {
        self.ratio.is_nan() || self.ratio < DEGENERATE_RATIO
    }
}

/// Reference neighbours farther apart than this do not define a normal, metres.
const NORMAL_MAX_GAP_M: f64 = 1.0;

/// The conditioning of the final pairs (see [`Conditioning`]).
fn conditioning(
    moved: &[Point2<f64>],
    dst: &[Point2<f64>],
    pairs: &[Correspondence],
) -> Option<Conditioning> {
    let normal = |j: usize| -> Option<Vector2<f64>> {
        let near = |k: usize| {
            dst.get(k)
                .filter(|q| (*q - dst[j]).norm() <= NORMAL_MAX_GAP_M)
        };
        let (a, b) = (
            j.checked_sub(1).and_then(near).unwrap_or(&dst[j]),
            near(j + 1).unwrap_or(&dst[j]),
        );
        let t = b - a;
        let len = t.norm();
        (len > 0.0).then(|| Vector2::new(-t.y, t.x) / len)
    };
    if pairs.is_empty() {
        return None;
    }
    let n = pairs.len() as f64;
    let m = pairs
        .iter()
        .map(|c| moved[c.src].coords)
        .sum::<Vector2<f64>>()
        / n;
    let l = (pairs
        .iter()
        .map(|c| (moved[c.src].coords - m).norm_squared())
        .sum::<f64>()
        / n)
        .sqrt();
    if l.is_nan() || l <= 0.0 {
        return None;
    }
    let mut h = Matrix3::zeros();
    let mut used = 0;
    for c in pairs {
        let Some(nrm) = normal(c.dst) else { continue };
        let r = moved[c.src].coords - m;
        let j = Vector3::new(nrm.x, nrm.y, (r.x * nrm.y - r.y * nrm.x) / l);
        h += j * j.transpose();
        used += 1;
    }
    if used < 3 {
        return None;
    }
    let e = SymmetricEigen::new(h / used as f64).eigenvalues;
    let mut ev = [e[0], e[1], e[2]];
    ev.sort_by(f64::total_cmp);
    let eigenvalues = [ev[0].max(0.0), ev[1], ev[2]];
    let ratio = if eigenvalues[2] > 0.0 {
        eigenvalues[0] / eigenvalues[2]
    } else {
        0.0
    };
    Some(Conditioning { eigenvalues, ratio })
}

impl Registration {
    /// True when the mean pair distance settled before the iteration limit.
    pub fn converged(&self) -> bool {
        self.stop == StopReason::Converged
    }

    /// True when too few final pairs are close (overlap below [`MIN_OVERLAP`], or NaN).
    pub fn no_overlap(&self) -> bool {
        self.overlap.is_nan() || self.overlap < MIN_OVERLAP
    }
}

/// The smaller of two fractions: of the final pairs closer than [`OVERLAP_GATE_M`] (source
/// points near the reference) and of the reference points that near the moved source points.
/// Both are needed: a small scan can settle inside a larger one with most of its own points
/// near surfaces.
fn overlap(moved: &[Point2<f64>], dst: &[Point2<f64>], pairs: &[Correspondence]) -> f64 {
    let gate_sq = OVERLAP_GATE_M * OVERLAP_GATE_M;
    if pairs.is_empty() || dst.is_empty() {
        return 0.0;
    }
    let forward = pairs.iter().filter(|p| p.dist_sq <= gate_sq).count() as f64 / pairs.len() as f64;
    // A reference point is near without a search when it is a close pair's, or close to the
    // source point paired with a scan neighbour of it; the others are searched.
    let (mut partner, mut near) = (vec![None; dst.len()], vec![false; dst.len()]);
    for p in pairs {
        partner[p.dst] = Some(p.src);
        near[p.dst] |= p.dist_sq <= gate_sq;
    }
    // Sized up front: the allocations of a registration do not depend on its pose.
    let mut unresolved = Vec::with_capacity(dst.len());
    for (j, q) in dst.iter().enumerate() {
        let by_neighbour = || {
            [j.wrapping_sub(1), j + 1]
                .iter()
                .filter_map(|&k| partner.get(k).copied().flatten())
                .any(|i: usize| (moved[i] - q).norm_squared() <= gate_sq)
        };
        if !near[j] && !by_neighbour() {
            unresolved.push(*q);
        }
    }
    let searched_near = Grid.build(moved).map_or(0, |index| {
        let mut matches = Matches::with_capacity(dst.len());
        index.match_all(&unresolved, &mut matches);
        matches
            .pairs
            .iter()
            .filter(|p| p.dist_sq <= gate_sq)
            .count()
    });
    let backward = (dst.len() - unresolved.len() + searched_near) as f64 / dst.len() as f64;
    forward.min(backward)
}

/// The buffers of a registration. Passing one workspace to successive registrations (one per
/// thread) reuses them: after the first, a registration allocates only for its
/// nearest-neighbour index and the overlap check. It also keeps the last reference index and
/// the first matching made with it: a registration with an equal matcher, the same selected
/// reference points and the same first queries (another variant of the same pair, or after
/// [`Registrar::prepare_in`]) takes them instead of building and searching again. What it
/// holds between calls never changes a result.
#[derive(Debug, Default)]
pub struct Workspace {
    src_idx: Vec<usize>,
    ref_idx: Vec<usize>,
    src: Vec<Return>,
    dst: Vec<Return>,
    src_pts: Vec<Point2<f64>>,
    dst_pts: Vec<Point2<f64>>,
    moved: Vec<Point2<f64>>,
    matches: Matches,
    weights: Vec<f64>,
    dists: Vec<f64>,
    scratch: Vec<f64>,
    /// A [`SharedReference`] of the matcher type that wrote it.
    shared: Option<Box<dyn Any + Send + Sync>>,
}

/// A reference index and the first matching made with it, kept by a [`Workspace`] for the
/// next registration that can use them.
struct SharedReference<M: Matcher> {
    /// The matcher that built `index`, from the points `reference`.
    matcher: M,
    reference: Vec<Point2<f64>>,
    index: M::Index,
    /// The queries of the first matching made with `index` (empty: none yet), and its result.
    queries: Vec<Point2<f64>>,
    first: Matches,
}

/// A registration method: estimates `t_ref_src` from two scans and an initial guess.
pub trait Registrar: Send + Sync {
    /// A short name, e.g. `HD_ICP`.
    fn name(&self) -> &str;

    /// Registers `source` (scan k) onto `reference` (scan k+1), starting from `init`, in the
    /// buffers of `workspace`.
    fn register_in(
        &self,
        workspace: &mut Workspace,
        source: &Scan,
        reference: &Scan,
        init: Isometry2<f64>,
    ) -> Result<Registration, IcpError>;

    /// Does in `workspace` what every registration of `source` onto `reference` from `init`
    /// begins with (with this method's selection and matcher): the reference index and the
    /// first matching, which [`Registrar::register_in`] then takes from the workspace instead of
    /// redoing. Needed by no one: it lets a caller time that shared work apart from the
    /// registrations of several variants of one pair. The default does nothing.
    fn prepare_in(
        &self,
        workspace: &mut Workspace,
        source: &Scan,
        reference: &Scan,
        init: Isometry2<f64>,
    ) -> Result<(), IcpError> {
        let _ = (workspace, source, reference, init);
        Ok(())
    }

    /// Registers `source` onto `reference` with buffers of its own.
    fn register(
        &self,
        source: &Scan,
        reference: &Scan,
        init: Isometry2<f64>,
    ) -> Result<Registration, IcpError> {
        self.register_in(&mut Workspace::default(), source, reference, init)
    }
}

/// Point-to-point ICP as a chain of stages (Algorithm 1): selection `S`, matching `M`, pair
/// weighting `W`, robust rejection `K` and minimisation `X`, plus the termination rule. The
/// paper's four variants are constructors in [`crate::variants`].
#[derive(Clone, Debug)]
pub struct Icp<S, M, W, K, X> {
    /// Name reported by [`Registrar::name`].
    pub name: String,
    /// Step 1: which points take part.
    pub selection: S,
    /// Step 2: nearest-neighbour index over the reference scan.
    pub matcher: M,
    /// Step 3: per-pair weights (eqs. 11–13).
    pub weighting: W,
    /// Step 4: robust factor on the weights.
    pub robust: K,
    /// Step 5: the minimiser of eq. 14.
    pub minimizer: X,
    /// Step 6: when to stop.
    pub termination: Termination,
}

impl<S, M, W, K, X> Icp<S, M, W, K, X> {
    /// The same chain with another matcher.
    pub fn with_matcher<M2>(self, matcher: M2) -> Icp<S, M2, W, K, X> {
        Icp {
            name: self.name,
            selection: self.selection,
            matcher,
            weighting: self.weighting,
            robust: self.robust,
            minimizer: self.minimizer,
            termination: self.termination,
        }
    }

    /// The same chain with another selection.
    pub fn with_selection<S2>(self, selection: S2) -> Icp<S2, M, W, K, X> {
        Icp {
            name: self.name,
            selection,
            matcher: self.matcher,
            weighting: self.weighting,
            robust: self.robust,
            minimizer: self.minimizer,
            termination: self.termination,
        }
    }

    /// The same chain with another pair weighting.
    pub fn with_weighting<W2>(self, weighting: W2) -> Icp<S, M, W2, K, X> {
        Icp {
            name: self.name,
            selection: self.selection,
            matcher: self.matcher,
            weighting,
            robust: self.robust,
            minimizer: self.minimizer,
            termination: self.termination,
        }
    }

    /// The same chain under another name.
    pub fn named(mut self, name: &str) -> Self {
        self.name = name.to_owned();
        self
    }

    /// The same chain with another termination rule.
    pub fn with_termination(mut self, termination: Termination) -> Self {
        self.termination = termination;
        self
    }
}

impl<S, M, W, K, X> Icp<S, M, W, K, X>
where
    S: Selection,
    M: Matcher + PartialEq + Clone + 'static,
{
    /// Alg. 1 step 1 and the first matching of step 2, from `init`: fills the workspace's
    /// points and matches, and returns the shared reference holding the index (taken from
    /// the workspace when it fits, built otherwise; the caller puts it back).
    fn prepare(
        &self,
        workspace: &mut Workspace,
        source: &Scan,
        reference: &Scan,
        init: Isometry2<f64>,
    ) -> Result<Box<SharedReference<M>>, IcpError> {
        self.termination.validate()?;
        for (name, value) in [
            ("init.translation", init.translation.vector.norm()),
            ("init.rotation", init.rotation.angle()),
        ] {
            if !value.is_finite() {
                return Err(IcpError::NonFinite {
                    what: name,
                    index: 0,
                    value,
                });
            }
        }
        for (scan, role) in [(source, ScanRole::Source), (reference, ScanRole::Reference)] {
            if scan.len() < MIN_POINTS {
                return Err(IcpError::TooFewPoints {
                    role,
                    got: scan.len(),
                    need: MIN_POINTS,
                });
            }
        }
        let Workspace {
            src_idx,
            ref_idx,
            src,
            dst,
            src_pts,
            dst_pts,
            moved,
            matches,
            shared,
            ..
        } = workspace;
        // Alg. 1 step 1: selection; the chosen points are gathered once, before the loop.
        self.selection
            .select(source.len(), reference.len(), src_idx, ref_idx);
        let gather = |idx: &[usize], scan: &Scan, out: &mut Vec<Return>| {
            out.clear();
            out.extend(idx.iter().map(|&i| scan.returns()[i]));
        };
        gather(src_idx, source, src);
        gather(ref_idx, reference, dst);
        for (returns, points) in [(&*src, &mut *src_pts), (&*dst, &mut *dst_pts)] {
            points.clear();
            points.extend(returns.iter().map(|r| r.point));
        }
        check_geometry(src_pts.iter(), ScanRole::Source)?;
        check_geometry(dst_pts.iter(), ScanRole::Reference)?;

        let cached = shared
            .take()
            .and_then(|any| any.downcast::<SharedReference<M>>().ok());
        let mut shared = match cached {
            Some(mut cached) => {
                if cached.matcher != self.matcher || cached.reference != *dst_pts {
                    cached.index = self.matcher.build(dst_pts)?;
                    cached.matcher = self.matcher.clone();
                    cached.reference.clone_from(dst_pts);
                    cached.queries.clear();
                }
                cached
            }
            None => Box::new(SharedReference {
                index: self.matcher.build(dst_pts)?,
                matcher: self.matcher.clone(),
                reference: dst_pts.clone(),
                queries: Vec::new(),
                first: Matches::default(),
            }),
        };
        let SharedReference {
            index,
            queries,
            first,
            ..
        } = &mut *shared;

        // Every buffer the loop writes is sized here: nothing is allocated inside the loop.
        let n = src.len();
        moved.clear();
        moved.extend(src_pts.iter().map(|p| init * p)); // eqs. 21, 22 at the start
        matches.clear();
        matches.reserve(n);
        if !queries.is_empty() && queries == moved {
            matches.copy_from(first);
        } else {
            index.match_all(moved, matches); // Alg. 1 step 2, first time
            queries.clone_from(moved);
            first.copy_from(matches);
        }
        Ok(shared)
    }
}

impl<S, M, W, K, X> Registrar for Icp<S, M, W, K, X>
where
    S: Selection,
    M: Matcher + PartialEq + Clone + 'static,
    W: PairWeighting,
    K: RobustKernel,
    X: Minimizer,
{
    fn name(&self) -> &str {
        &self.name
    }

    fn prepare_in(
        &self,
        workspace: &mut Workspace,
        source: &Scan,
        reference: &Scan,
        init: Isometry2<f64>,
    ) -> Result<(), IcpError> {
        let shared = self.prepare(workspace, source, reference, init)?;
        workspace.shared = Some(shared);
        Ok(())
    }

    fn register_in(
        &self,
        workspace: &mut Workspace,
        source: &Scan,
        reference: &Scan,
        init: Isometry2<f64>,
    ) -> Result<Registration, IcpError> {
        let shared = self.prepare(workspace, source, reference, init)?;
        let index = &shared.index;
        let Workspace {
            src,
            dst,
            src_pts,
            dst_pts,
            moved,
            matches,
            weights,
            dists,
            scratch,
            ..
        } = &mut *workspace;
        for buffer in [&mut *weights, &mut *dists, &mut *scratch] {
            buffer.clear();
            buffer.reserve(src.len());
        }

        // `moved` and `matches` hold the first matching, at `init`.
        let mut t_ref_src = init;
        let mut previous_mean: Option<f64> = None;
        let mut last_weight_sum = 0.0;
        let mut iterations = 0;
        let (stop, mean_dist_m) = loop {
            let pairs = &matches.pairs;
            dists.clear();
            dists.extend(pairs.iter().map(|p| p.dist_sq.sqrt()));
            let mean = dists.iter().sum::<f64>() / dists.len() as f64; // Alg. 1 step 6
            if let Some(prev) = previous_mean {
                if self.termination.converged(prev, mean) {
                    break (StopReason::Converged, mean);
                }
            }
            if iterations == self.termination.max_iterations {
                break (StopReason::MaxIterations, mean);
            }
            // Alg. 1 step 3, eqs. 11–13: the scheme's weight of each pair.
            let batch = PairBatch {
                pairs,
                src,
                dst,
                src_moved: moved,
                rotation_ref_src: t_ref_src.rotation,
            };
            self.weighting.weigh_all(&batch, weights);
            // Alg. 1 step 4: the robust factor (Huber), from the pair distances.
            self.robust.reweight(dists, weights, scratch);
            // Alg. 1 step 5, eqs. 15–20: the increment, then eqs. 21, 22: accumulate it.
            let increment = self.minimizer.solve(moved, dst_pts, pairs, weights)?;
            last_weight_sum = weights.iter().sum();
            t_ref_src = increment * t_ref_src;
            iterations += 1;
            previous_mean = Some(mean);
            for (m, p) in moved.iter_mut().zip(src_pts.iter()) {
                *m = t_ref_src * p; // eqs. 21, 22: the accumulated transform applied to scan k
            }
            index.match_all(moved, matches); // Alg. 1 step 2
        };
        let registration = Registration {
            t_ref_src,
            iterations,
            stop,
            n_pairs: matches.pairs.len(),
            weight_sum: last_weight_sum,
            mean_dist_m,
            conditioning: conditioning(moved, dst_pts, &matches.pairs),
            overlap: overlap(moved, dst_pts, &matches.pairs),
        };
        workspace.shared = Some(shared);
        Ok(registration)
    }
}
