//! The normal equations of the smoother: which 3-vectors are free (a [`Layout`]), and the
//! linearisation of the prior and registration factors over them into any [`Sink`] (the sparse
//! system of the batch smoother or the dense one of the causal window).

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use super::factors;
use super::{Geometry, MotionPrior, SolveStop};

/// A 3-vector's mean and information.
pub(crate) type Gaussian3 = (Vector3<f64>, Matrix3<f64>);

/// A registration in the smoother: `t_ref_src` parameters `z` of `source → reference`, the
/// information its factor weighs it by (the inverse of its covariance, or of its own part of
/// it under scan errors) and its covariance as given.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Reg {
    pub source: usize,
    pub reference: usize,
    pub z: Vector3<f64>,
    pub info: Matrix3<f64>,
    /// The covariance of `z` as given (all of its error, its scans' share included).
    pub cov: Matrix3<f64>,
}

/// Every scan's pose `(x m, y m, θ rad)`, body twist `(surge m/s, sway m/s, yaw rad/s)`, body
/// acceleration `(surge m/s², sway m/s², yaw rad/s²)` (zero under white noise on acceleration,
/// whose state has none) and error `(x m, y m, θ rad)`: where the scan's own errors put it
/// beside its pose, as every registration that uses the scan sees it (zero when the model has
/// no scan errors, see [`super::ScanErrors`]).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Estimates {
    pub poses: Vec<Vector3<f64>>,
    pub twists: Vec<Vector3<f64>>,
    pub accels: Vec<Vector3<f64>>,
    pub errors: Vec<Vector3<f64>>,
}

impl Estimates {
    /// `poses` and `twists`, with zero accelerations and errors.
    pub fn new(poses: Vec<Vector3<f64>>, twists: Vec<Vector3<f64>>) -> Self {
        let zeros = vec![Vector3::zeros(); poses.len()];
        Self {
            poses,
            twists,
            accels: zeros.clone(),
            errors: zeros,
        }
    }

    /// The 3-vector of `kind` ([`POSE`], [`TWIST`], [`ACCEL`] or [`ERROR`]) of `state`.
    pub fn get(&self, kind: usize, state: usize) -> &Vector3<f64> {
        match kind {
            POSE => &self.poses[state],
            TWIST => &self.twists[state],
            ACCEL => &self.accels[state],
            _ => &self.errors[state],
        }
    }

    fn get_mut(&mut self, kind: usize, state: usize) -> &mut Vector3<f64> {
        match kind {
            POSE => &mut self.poses[state],
            TWIST => &mut self.twists[state],
            ACCEL => &mut self.accels[state],
            _ => &mut self.errors[state],
        }
    }

    /// The states `range`, as estimates of their own.
    pub fn slice(&self, range: std::ops::Range<usize>) -> Self {
        Self {
            poses: self.poses[range.clone()].to_vec(),
            twists: self.twists[range.clone()].to_vec(),
            accels: self.accels[range.clone()].to_vec(),
            errors: self.errors[range].to_vec(),
        }
    }

    /// Scan `state`'s first `order` derivatives: pose, twist and, for 3, acceleration.
    fn derivatives(&self, state: usize, order: usize) -> [Vector3<f64>; 3] {
        let mut out = [self.poses[state], self.twists[state], Vector3::zeros()];
        if order > 2 {
            out[ACCEL] = self.accels[state];
        }
        out
    }

    /// `self − other` for the 3-vector of `kind` of `state` in `self` and `at` in `other`
    /// (a pose's angle wrapped).
    pub fn minus(
        &self,
        geometry: Geometry,
        kind: usize,
        state: usize,
        other: &Self,
        at: usize,
    ) -> Vector3<f64> {
        let (a, b) = (self.get(kind, state), other.get(kind, at));
        if kind == POSE {
            factors::pose_minus(geometry, a, b)
        } else {
            a - b
        }
    }
}

/// A state's pose, in [`Layout::state_blocks`] and [`Estimates::get`].
pub(crate) const POSE: usize = 0;
/// A state's twist.
pub(crate) const TWIST: usize = 1;
/// A state's acceleration.
pub(crate) const ACCEL: usize = 2;
/// A state's error.
pub(crate) const ERROR: usize = 3;

/// The free 3-vectors (blocks) of the states `first..first + len`: where the model has them an
/// error, then a pose, a twist and, where the model has them, an acceleration each, state by
/// state; scan 0's pose, which fixes the frame (the identity), is not free.
#[derive(Clone, Debug)]
pub(crate) struct Layout {
    first: usize,
    blocks_of: Vec<[Option<usize>; 4]>,
    blocks: usize,
}

impl Layout {
    pub fn new(first: usize, len: usize, errors: bool, accels: bool) -> Self {
        let mut blocks = 0;
        let mut next = |free: bool| {
            free.then(|| {
                blocks += 1;
                blocks - 1
            })
        };
        // Error first: a registration ties a scan's pose and error to those of a scan up to L
        // later, so the band of H spans 3L + 1 blocks this way against 3L + 2 with the error
        // last (35 → 32 scalars at L = 3; the marginals cost the band's width squared; an
        // acceleration adds a block per scan: 41 scalars).
        let blocks_of = (first..first + len)
            .map(|state| {
                let error = next(errors);
                let pose = next(state != 0);
                let twist = next(true);
                [pose, twist, next(accels), error]
            })
            .collect();
        Self {
            first,
            blocks_of,
            blocks,
        }
    }

    /// Number of free scalars.
    pub fn dim(&self) -> usize {
        3 * self.blocks
    }

    pub fn contains(&self, state: usize) -> bool {
        state >= self.first && state < self.first + self.blocks_of.len()
    }

    /// The blocks of `state` in `[pose, twist, acceleration, error]` order (`None` where not
    /// free or not in the layout).
    pub fn state_blocks(&self, state: usize) -> [Option<usize>; 4] {
        if self.contains(state) {
            self.blocks_of[state - self.first]
        } else {
            [None; 4]
        }
    }

    /// The block of `state`'s pose, if free and in the layout.
    pub fn pose(&self, state: usize) -> Option<usize> {
        self.state_blocks(state)[POSE]
    }

    /// The block of `state`'s twist, if in the layout.
    pub fn twist(&self, state: usize) -> Option<usize> {
        self.state_blocks(state)[TWIST]
    }

    /// The block of `state`'s acceleration, if the model has them and the state is in the
    /// layout.
    pub fn accel(&self, state: usize) -> Option<usize> {
        self.state_blocks(state)[ACCEL]
    }

    /// The block of `state`'s error, if the model has them and the state is in the layout.
    pub fn error(&self, state: usize) -> Option<usize> {
        self.state_blocks(state)[ERROR]
    }

    fn states(&self) -> std::ops::Range<usize> {
        self.first..self.first + self.blocks_of.len()
    }

    /// Applies the step `delta` (in this layout) times `scale` to `est`.
    pub fn apply(&self, geometry: Geometry, est: &mut Estimates, delta: &[f64], scale: f64) {
        let at = |b: usize| Vector3::new(delta[3 * b], delta[3 * b + 1], delta[3 * b + 2]) * scale;
        for (state, blocks) in self.states().zip(&self.blocks_of) {
            for (kind, b) in blocks.iter().enumerate() {
                let Some(b) = *b else { continue };
                let v = est.get_mut(kind, state);
                *v += at(b);
                if kind == POSE && geometry == Geometry::Se2 {
                    v.z = factors::wrap_rad(v.z);
                }
            }
        }
    }

    /// Copies the states of this layout from `from` into `to`.
    pub fn copy(&self, from: &Estimates, to: &mut Estimates) {
        let states = self.states();
        to.poses[states.clone()].copy_from_slice(&from.poses[states.clone()]);
        to.twists[states.clone()].copy_from_slice(&from.twists[states.clone()]);
        to.accels[states.clone()].copy_from_slice(&from.accels[states.clone()]);
        to.errors[states.clone()].copy_from_slice(&from.errors[states]);
    }
}

/// What a step [`descend`] took (`taken`) says of the solve, for a Gauss–Newton step `δ` of
/// Newton decrement `decrement` (`δᵀHδ = −gᵀδ`: its squared length in the estimate's own σ):
/// `None` while it goes on, else how it stopped.
pub(crate) fn stopped(taken: Option<Descent>, decrement: f64, tolerance: f64) -> Option<SolveStop> {
    match taken {
        Some(_) if decrement > tolerance => None,
        Some(_) => Some(SolveStop::Converged),
        None => Some(SolveStop::NoDescent),
    }
}

/// Halvings of a Gauss–Newton step at most before [`descend`] gives up (a step 4096 times
/// shorter than Gauss–Newton's).
const MAX_HALVINGS: usize = 12;

/// A step [`descend`] took: its scale (of the Gauss–Newton step) and the cost at the states
/// it moved to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Descent {
    pub scale: f64,
    pub cost: f64,
}

/// Step control of the smoothers' Gauss–Newton: moves `est` by the step `delta` (laid out as
/// `layout`), halved until the cost (`cost`, at the trial states in `trial`, a scratch copy
/// of `est`) is no higher than `cost_now`; returns the step taken, or `None` (and `est`
/// unchanged) when no step down to [`MAX_HALVINGS`] halvings lowers it. Without it, after
/// the aces log's 18 s pause (where the prior barely ties the scans) full steps diverged until
/// the causal window's system was no longer positive definite.
pub(crate) fn descend(
    geometry: Geometry,
    layout: &Layout,
    est: &mut Estimates,
    trial: &mut Estimates,
    delta: &[f64],
    cost_now: f64,
    cost: impl Fn(&Estimates) -> f64,
) -> Option<Descent> {
    let mut scale = 1.0;
    for _ in 0..=MAX_HALVINGS {
        layout.copy(est, trial);
        layout.apply(geometry, trial, delta, scale);
        let at = cost(trial);
        if at <= cost_now {
            layout.copy(trial, est);
            return Some(Descent { scale, cost: at });
        }
        scale *= 0.5;
    }
    None
}

/// Where a linearisation accumulates `H = Σ Jᵀ W J` and `g = Σ Jᵀ W r`, block by block.
pub(crate) trait Sink {
    /// Adds `m` to block `(bi, bj)` of H; called once per ordered pair with `bi ≤ bj`.
    fn add_h(&mut self, bi: usize, bj: usize, m: &Matrix3<f64>);
    /// Adds `v` to block `bi` of g.
    fn add_g(&mut self, bi: usize, v: &Vector3<f64>);
}

/// A sink that keeps nothing: the factors' cost alone.
pub(crate) struct Discard;

impl Sink for Discard {
    fn add_h(&mut self, _: usize, _: usize, _: &Matrix3<f64>) {}
    fn add_g(&mut self, _: usize, _: &Vector3<f64>) {}
}

/// Adds one factor (residual `r`, information `info`, Jacobian blocks against `blocks`).
pub(crate) fn accumulate<const R: usize, S: Sink>(
    sink: &mut S,
    blocks: &[(Option<usize>, SMatrix<f64, R, 3>)],
    r: &SVector<f64, R>,
    info: &SMatrix<f64, R, R>,
) {
    let wr = info * r;
    for (bi, ji) in blocks {
        let Some(bi) = *bi else { continue };
        let jtw = ji.transpose() * info;
        sink.add_g(bi, &(ji.transpose() * wr));
        for (bj, jj) in blocks {
            let Some(bj) = *bj else { continue };
            if bi <= bj {
                sink.add_h(bi, bj, &(jtw * jj));
            }
        }
    }
}

/// Adds a Gaussian on one block (`r` its residual, `info` its information) into `sink`;
/// returns its cost.
fn add_gaussian<S: Sink>(
    sink: &mut S,
    block: Option<usize>,
    r: &Vector3<f64>,
    info: &Matrix3<f64>,
) -> f64 {
    accumulate(sink, &[(block, Matrix3::identity())], r, info);
    0.5 * r.dot(&(info * r))
}

/// The factors of a run: its timestamps, registrations, motion prior and its process noise,
/// and robust threshold.
#[derive(Clone, Debug)]
pub(crate) struct Model<'a> {
    pub geometry: Geometry,
    pub times_s: &'a [f64],
    pub regs: &'a [Reg],
    pub prior: MotionPrior,
    pub qc: [f64; 3],
    pub huber_k: f64,
    /// Scan 0's twist: mean and information, if known.
    pub twist0: Option<Gaussian3>,
    /// Scan 0's acceleration (white noise on jerk only): mean and information, if known.
    pub accel0: Option<Gaussian3>,
    /// The information of each scan's error, zero-mean (world frame), where the model has
    /// scan errors; the registrations' `info` is then that of their own, independent part
    /// (see [`super::ScanErrors`]).
    pub scan_errors: Option<&'a [Matrix3<f64>]>,
}

impl Model<'_> {
    /// The layout of the states `first..first + len` under this model.
    pub fn layout(&self, first: usize, len: usize) -> Layout {
        Layout::new(
            first,
            len,
            self.scan_errors.is_some(),
            self.prior == MotionPrior::WhiteJerk,
        )
    }

    pub fn dt_s(&self, k: usize) -> f64 {
        self.times_s[k + 1] - self.times_s[k]
    }

    /// Linearises the prior between `k` and `k + 1` into `sink`; returns its cost `½ rᵀWr`.
    pub fn add_prior<S: Sink>(
        &self,
        est: &Estimates,
        layout: &Layout,
        k: usize,
        sink: &mut S,
    ) -> f64 {
        match self.prior {
            MotionPrior::WhiteAcceleration => self.add_prior_of::<6, 4, S>(est, layout, k, sink),
            MotionPrior::WhiteJerk => self.add_prior_of::<9, 6, S>(est, layout, k, sink),
        }
    }

    /// The prior between `k` and `k + 1` linearised at `est`, for a state of `R/3`
    /// derivatives ([`factors::prior`]).
    pub fn linearise_prior<const R: usize, const B: usize>(
        &self,
        est: &Estimates,
        k: usize,
    ) -> factors::PriorLinearised<R, B> {
        let order = R / 3;
        let (at_k, at_k1) = (est.derivatives(k, order), est.derivatives(k + 1, order));
        factors::prior(self.geometry, &at_k[..order], &at_k1[..order], self.dt_s(k))
    }

    /// [`Self::add_prior`] for a state of `R/3` derivatives and `B = 2R/3` blocks.
    fn add_prior_of<const R: usize, const B: usize, S: Sink>(
        &self,
        est: &Estimates,
        layout: &Layout,
        k: usize,
        sink: &mut S,
    ) -> f64 {
        let order = R / 3;
        let lin = self.linearise_prior::<R, B>(est, k);
        let info = factors::prior_information::<R>(&self.qc, self.dt_s(k));
        let blocks: [_; B] = std::array::from_fn(|b| {
            let (state, kind) = (k + b / order, b % order);
            (layout.state_blocks(state)[kind], lin.jacobians[b])
        });
        accumulate(sink, &blocks, &lin.residual, &info);
        0.5 * lin.residual.dot(&(info * lin.residual))
    }

    /// Linearises the priors on scan 0's twist and acceleration, if any, into `sink`; returns
    /// their cost.
    pub fn add_initial<S: Sink>(&self, est: &Estimates, layout: &Layout, sink: &mut S) -> f64 {
        let mut cost = 0.0;
        if let Some((mean, info)) = self.twist0 {
            cost += add_gaussian(sink, layout.twist(0), &(est.twists[0] - mean), &info);
        }
        if let Some((mean, info)) = self.accel0 {
            cost += add_gaussian(sink, layout.accel(0), &(est.accels[0] - mean), &info);
        }
        cost
    }

    /// Linearises the zero-mean prior on scan `k`'s error, if the model has scan errors, into
    /// `sink`; returns its cost.
    pub fn add_scan_error<S: Sink>(
        &self,
        est: &Estimates,
        layout: &Layout,
        k: usize,
        sink: &mut S,
    ) -> f64 {
        let Some(infos) = self.scan_errors else {
            return 0.0;
        };
        add_gaussian(sink, layout.error(k), &est.errors[k], &infos[k])
    }

    /// Linearises registration `i` (Huber-weighted, IRLS) into `sink`; returns its robust cost.
    /// It is predicted between its scans as their errors place them (pose plus error; the
    /// errors are zero without scan errors), so the part of its error its scans share with
    /// their other registrations is theirs, and only its own part is weighed here.
    pub fn add_reg<S: Sink>(
        &self,
        est: &Estimates,
        layout: &Layout,
        i: usize,
        sink: &mut S,
    ) -> f64 {
        let reg = &self.regs[i];
        let seen = |k: usize| est.poses[k] + est.errors[k];
        let (pred, j_src, j_ref) =
            factors::relative(self.geometry, &seen(reg.source), &seen(reg.reference));
        let r = factors::pose_minus(self.geometry, &pred, &reg.z);
        let d = r.dot(&(reg.info * r)).max(0.0).sqrt();
        let w = factors::huber_weight(d, self.huber_k);
        let blocks = [
            (layout.pose(reg.source), j_src),
            (layout.error(reg.source), j_src),
            (layout.pose(reg.reference), j_ref),
            (layout.error(reg.reference), j_ref),
        ];
        accumulate(sink, &blocks, &r, &(reg.info * w));
        if d <= self.huber_k {
            0.5 * d * d
        } else {
            self.huber_k * d - 0.5 * self.huber_k * self.huber_k
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn states(n: usize) -> Estimates {
        Estimates::new(vec![Vector3::zeros(); n], vec![Vector3::zeros(); n])
    }

    #[test]
    fn a_step_is_halved_until_the_cost_does_not_rise_and_refused_when_it_always_does() {
        // One free twist (scan 0's pose fixes the frame): cost (u − 1)² along surge.
        let layout = Layout::new(0, 1, false, false);
        let cost = |e: &Estimates| (e.twists[0].x - 1.0).powi(2);
        let (mut est, mut trial) = (states(1), states(1));
        // From u = 0 (cost 1) a step to u = 6 overshoots (25), so does u = 3 (4); halved
        // twice it lands on u = 1.5 (0.25).
        let delta = [6.0, 0.0, 0.0];
        let taken = descend(
            Geometry::Se2,
            &layout,
            &mut est,
            &mut trial,
            &delta,
            1.0,
            cost,
        );
        assert_eq!(
            taken,
            Some(Descent {
                scale: 0.25,
                cost: 0.25
            })
        );
        assert_eq!(est.twists[0].x, 1.5);
        // Away from the minimum every step raises the cost: nothing moves.
        let away = [1.0, 0.0, 0.0];
        let taken = descend(
            Geometry::Se2,
            &layout,
            &mut est,
            &mut trial,
            &away,
            0.25,
            cost,
        );
        assert_eq!(taken, None);
        assert_eq!(est.twists[0].x, 1.5);
    }
}
