//! The ICP loop (Naus & Marchel 2019, Algorithm 1 and eqs. 14, 21, 22) as a chain of stages.

use nalgebra::Isometry2;

use crate::error::{ConfigError, ScanRole};
use crate::matching::{Correspondence, Matcher};
use crate::metric::Metric;
use crate::minimize::Minimizer;
use crate::moving::MovingReturns;
use crate::pairs::PairSet;
use crate::quality::{conditioning, overlap};
use crate::registration::{check_init, Prepared, Registrar, Registration};
use crate::robust::RobustKernel;
use crate::scan::{check_geometry, MIN_POINTS};
use crate::select::Selection;
use crate::spec::VariantSpec;
use crate::surface::SurfaceParams;
use crate::termination::{StopReason, Termination, CYCLE_MEMORY};
use crate::weighting::{BatchWeighting, PairWeighting, Weighting};
use crate::workspace::Workspace;
use crate::{IcpError, SensorModel};

/// ICP as a chain of stages (Algorithm 1): selection, matching, the error metric, pair
/// weighting, robust rejection and minimisation, plus the termination rule. Every stage is a
/// trait object, built from its registered kind by [`VariantSpec::build`] or written in user
/// code and swapped in with the `with_*` methods.
pub struct Icp {
    pub(crate) name: String,
    pub(crate) source: Option<String>,
    pub(crate) sensor: SensorModel,
    pub(crate) selection: Box<dyn Selection>,
    pub(crate) matcher: Box<dyn Matcher>,
    pub(crate) surfaces: SurfaceParams,
    pub(crate) metric: Box<dyn Metric>,
    pub(crate) weighting: Weighting,
    pub(crate) robust: Box<dyn RobustKernel>,
    pub(crate) minimizer: Box<dyn Minimizer>,
    pub(crate) termination: Termination,
    pub(crate) moving: Box<dyn MovingReturns>,
    /// Whether a registration also computes the grouped jackknife of its covariance (see
    /// [`Registrar::set_jackknife`]).
    pub(crate) jackknife: bool,
}

impl Icp {
    /// The same chain with another pair weighting (its [`PairWeighting::spec`] is what reports
    /// show).
    pub fn with_weighting(mut self, weighting: impl PairWeighting + 'static) -> Self {
        self.weighting = Weighting::Pair(Box::new(weighting));
        self
    }

    /// The same chain with a pair weighting that weighs each iteration at once and may fail
    /// (one written outside Rust; its [`BatchWeighting::spec`] is what reports show).
    pub fn with_batch_weighting(mut self, weighting: impl BatchWeighting + 'static) -> Self {
        self.weighting = Weighting::Batch(Box::new(weighting));
        self
    }

    /// The same chain with another robust kernel.
    pub fn with_robust(mut self, robust: impl RobustKernel + 'static) -> Self {
        self.robust = Box::new(robust);
        self
    }

    /// The same chain with another matcher.
    pub fn with_matcher(mut self, matcher: impl Matcher + 'static) -> Self {
        self.matcher = Box::new(matcher);
        self
    }

    /// The same chain with another selection.
    pub fn with_selection(mut self, selection: impl Selection + 'static) -> Self {
        self.selection = Box::new(selection);
        self
    }

    /// The same chain with another metric and minimiser, `Err` when the minimiser cannot
    /// minimise the metric's cost.
    pub fn with_metric(
        mut self,
        metric: impl Metric + 'static,
        minimizer: impl Minimizer + 'static,
    ) -> Result<Self, ConfigError> {
        minimizer
            .check(&metric)
            .map_err(ConfigError::Incompatible)?;
        self.metric = Box::new(metric);
        self.minimizer = Box::new(minimizer);
        Ok(self)
    }

    /// The same chain with another termination rule.
    pub fn with_termination(mut self, termination: Termination) -> Self {
        self.termination = termination;
        self
    }

    /// The same chain under another name (and without the source of the one it came from).
    pub fn named(mut self, name: &str) -> Self {
        self.name = name.to_owned();
        self.source = None;
        self
    }
}

/// A fingerprint of a matching (FNV-1a over the matched reference indices), never 0.
fn fingerprint(pairs: &[Correspondence]) -> u64 {
    let hash = pairs.iter().fold(0xcbf2_9ce4_8422_2325_u64, |h, c| {
        (h ^ c.dst as u64).wrapping_mul(0x0100_0000_01b3)
    });
    hash.max(1)
}

/// The entries of `all` at `idx`, into `out` (cleared first).
fn gather<T: Copy>(idx: &[usize], all: &[T], out: &mut Vec<T>) {
    out.clear();
    out.extend(idx.iter().map(|&i| all[i]));
}

impl Registrar for Icp {
    fn name(&self) -> &str {
        &self.name
    }

    fn spec(&self) -> VariantSpec {
        VariantSpec {
            name: self.name.clone(),
            source: self.source.clone(),
            selection: self.selection.spec(),
            matcher: self.matcher.spec(),
            surfaces: self.surfaces,
            metric: self.metric.spec(),
            weighting: self.weighting.spec(),
            robust: self.robust.spec(),
            minimizer: Some(self.minimizer.spec()),
            sensor: self.sensor,
            termination: self.termination,
            moving: self.moving.spec(),
        }
    }

    fn moving(&self) -> Option<&dyn MovingReturns> {
        (self.moving.lag_scans() > 0).then_some(self.moving.as_ref())
    }

    fn surface_params(&self) -> SurfaceParams {
        self.surfaces
    }

    fn set_jackknife(&mut self, on: bool) {
        self.jackknife = on;
    }

    fn register_prepared(
        &self,
        workspace: &mut Workspace,
        source: Prepared<'_>,
        reference: Prepared<'_>,
        init: Isometry2<f64>,
    ) -> Result<Registration, IcpError> {
        self.termination
            .validate()
            .map_err(|source| ConfigError::Section {
                section: "termination",
                source,
            })?;
        check_init(&init)?;
        for (scan, role) in [
            (&source, ScanRole::Source),
            (&reference, ScanRole::Reference),
        ] {
            scan.check(&self.surfaces, role)?;
            if scan.scan.len() < MIN_POINTS {
                return Err(IcpError::TooFewPoints {
                    role,
                    got: scan.scan.len(),
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
            src_surfaces,
            dst_surfaces,
            moved,
            pairs,
            dists,
            residuals,
            weights,
            scratch,
            index,
        } = workspace;

        // Alg. 1 step 1: selection; the chosen points are gathered once, before the loop.
        self.selection
            .select(source.scan.len(), reference.scan.len(), src_idx, ref_idx);
        gather(src_idx, source.scan.returns(), src);
        gather(ref_idx, reference.scan.returns(), dst);
        for (returns, points) in [(&*src, &mut *src_pts), (&*dst, &mut *dst_pts)] {
            points.clear();
            points.extend(returns.iter().map(|r| r.point));
        }
        check_geometry(src_pts.iter(), ScanRole::Source)?;
        check_geometry(dst_pts.iter(), ScanRole::Reference)?;
        gather(ref_idx, reference.surfaces.points(), dst_surfaces);
        if self.metric.needs_source_surfaces() {
            gather(src_idx, source.surfaces.points(), src_surfaces);
        } else {
            src_surfaces.clear();
        }

        // Every buffer the loop writes is sized here: nothing is allocated inside the loop.
        let n = src.len();
        for buffer in [&mut *dists, &mut *residuals, &mut *weights, &mut *scratch] {
            buffer.clear();
            buffer.reserve(n);
        }
        pairs.clear();
        pairs.reserve(n);
        moved.clear();
        moved.extend(src_pts.iter().map(|p| init * p)); // eqs. 21, 22 at the start

        // Alg. 1 step 2, first time (the index and these pairs are the previous registration's
        // when it had the same reference points, matcher and start: the variants of a pair).
        let index = index.first_matching(self.matcher.as_ref(), dst_pts, moved, pairs)?;

        let mut t_ref_src = init;
        let mut previous_mean: Option<f64> = None;
        // Fingerprints of the last matchings, for the cycle rule (0: none yet).
        let mut seen = [0u64; CYCLE_MEMORY];
        let mut small_update = false;
        let mut last_weight_sum = 0.0;
        let mut iterations = 0;
        // The pairs of the current matching as the stages see them (in the loop and after it).
        macro_rules! pair_set {
            () => {
                PairSet {
                    pairs,
                    src,
                    dst,
                    src_moved: moved,
                    dst_points: dst_pts,
                    src_surfaces,
                    dst_surfaces,
                    t_ref_src,
                }
            };
        }
        let (stop, mean, used) = loop {
            let set = pair_set!();
            dists.clear();
            dists.extend(set.pairs.iter().map(|p| p.dist_sq.sqrt()));
            // The metric's residuals; NaN marks a pair it cannot use.
            self.metric.residuals(&set, dists, residuals);
            // Their count and mean, in one pass (summed in order from −0, as `Iterator::sum`).
            let (used, sum) = residuals.iter().fold((0usize, -0.0f64), |(n, sum), &r| {
                if r.is_nan() {
                    (n, sum)
                } else {
                    (n + 1, sum + r)
                }
            });
            let mean = sum / used as f64;
            // Alg. 1 step 6: the paper's rule, then the update rule, then the limit.
            if let Some(prev) = previous_mean {
                if self.termination.converged(prev, mean) {
                    break (StopReason::Converged, mean, used);
                }
            }
            if small_update {
                break (StopReason::SmallUpdate, mean, used);
            }
            if self.termination.stop_on_repeated_matching {
                // A loop: the matching of two or more iterations ago again. (The previous
                // iteration's again is no loop: the steps over fixed pairs go on converging.)
                let print = fingerprint(pairs);
                let previous = (iterations + CYCLE_MEMORY - 1) % CYCLE_MEMORY;
                if iterations > 0 && (0..CYCLE_MEMORY).any(|k| k != previous && seen[k] == print) {
                    break (StopReason::RepeatedMatching, mean, used);
                }
                seen[iterations % CYCLE_MEMORY] = print;
            }
            if iterations == self.termination.max_iterations {
                break (StopReason::MaxIterations, mean, used);
            }
            // Alg. 1 step 3, eqs. 11–13: the scheme's weight of each usable pair.
            self.weighting.weigh(&set, iterations, weights)?;
            if used < residuals.len() {
                for (w, r) in weights.iter_mut().zip(residuals.iter()) {
                    if r.is_nan() {
                        *w = 0.0;
                    }
                }
            }
            // Alg. 1 step 4: the robust factor (Huber), from the batch's distances.
            self.robust.reweight(dists, residuals, weights, scratch);
            // Alg. 1 step 5, eqs. 14–20: the increment, then eqs. 21, 22: accumulate it.
            let increment = self.minimizer.solve(&set, weights, self.metric.as_ref())?;
            last_weight_sum = weights.iter().sum();
            small_update = self.termination.small_update(
                increment.translation.vector.norm(),
                increment.rotation.angle().abs(),
            );
            t_ref_src = increment * t_ref_src;
            iterations += 1;
            previous_mean = Some(mean);
            for (m, p) in moved.iter_mut().zip(src_pts.iter()) {
                *m = t_ref_src * p; // eqs. 21, 22: the accumulated transform applied to scan k
            }
            index.match_all(moved, pairs); // Alg. 1 step 2
        };
        // The closed-form covariance, once, with the weights of the final iteration (pair i
        // is source point i's in every iteration), those of pairs now unusable zeroed; made
        // afresh when no step was taken. The buffers are sized: nothing is allocated.
        let (covariance, jackknife_covariance) = {
            let set = pair_set!();
            let fresh = iterations == 0 || weights.len() != residuals.len();
            if fresh {
                self.weighting.weigh(&set, iterations, weights)?;
            }
            for (w, r) in weights.iter_mut().zip(residuals.iter()) {
                if r.is_nan() {
                    *w = 0.0;
                }
            }
            if fresh {
                self.robust.reweight(dists, residuals, weights, scratch);
            }
            let sums = self.metric.sandwich(&set, weights, &self.sensor);
            (
                sums.map(|s| s.covariance(&t_ref_src)),
                sums.filter(|_| self.jackknife)
                    .map(|s| s.jackknife_covariance(&t_ref_src)),
            )
        };
        Ok(Registration {
            t_ref_src,
            iterations,
            stop,
            n_pairs: used,
            n_unusable: pairs.len() - used,
            weight_sum: last_weight_sum,
            mean_residual_m: mean,
            conditioning: conditioning(moved, dst_surfaces, pairs),
            overlap: overlap(moved, dst_pts, pairs),
            covariance,
            jackknife_covariance,
        })
    }
}
