//! Pair weighting by a scheme that weighs a whole iteration at once and may fail: one written
//! outside Rust, such as a Python function (the `icp_bench` package). Its weights are checked
//! (one per pair, finite, ≥ 0) before they reach the loop, and a failure stops the
//! registration with [`IcpError::WeightingFailed`], naming the iteration.
//!
//! A chain holds either kind through [`Weighting`]; the registered schemes keep their
//! allocation-free path ([`PairWeighting::weigh_all`]).

use crate::pairs::PairSet;
use crate::registry::StageSpec;
use crate::weighting::PairWeighting;
use crate::IcpError;

/// A scheme that gives every pair of an iteration its weight `w_i` of eq. 14 in one call,
/// and may fail.
pub trait BatchWeighting: Send + Sync {
    /// What this stage is, for reports (e.g. kind `python:<qualified name>`).
    fn spec(&self) -> StageSpec;

    /// The weights of every pair of `set`, in order, into `out` (cleared first), at
    /// minimisation step `iteration` (from 0); `Err` with why when the scheme failed.
    fn weigh_batch(
        &self,
        set: &PairSet<'_>,
        iteration: usize,
        out: &mut Vec<f64>,
    ) -> Result<(), String>;
}

/// The weighting stage of a chain: a scheme of one pair at a time (the registered kinds and
/// user code in Rust), or a fallible batch scheme.
pub(crate) enum Weighting {
    /// Weighs one pair at a time; never fails.
    Pair(Box<dyn PairWeighting>),
    /// Weighs an iteration at once; may fail.
    Batch(Box<dyn BatchWeighting>),
}

impl Weighting {
    /// What the stage is, for reports.
    pub(crate) fn spec(&self) -> StageSpec {
        match self {
            Weighting::Pair(w) => w.spec(),
            Weighting::Batch(w) => w.spec(),
        }
    }

    /// The weights of every pair of `set` into `out` (cleared first) at step `iteration`;
    /// a batch scheme's checked.
    pub(crate) fn weigh(
        &self,
        set: &PairSet<'_>,
        iteration: usize,
        out: &mut Vec<f64>,
    ) -> Result<(), IcpError> {
        match self {
            Weighting::Pair(w) => {
                w.weigh_all(set, out);
                Ok(())
            }
            Weighting::Batch(w) => w
                .weigh_batch(set, iteration, out)
                .and_then(|()| check_weights(out, set.pairs.len()))
                .map_err(|why| IcpError::WeightingFailed { iteration, why }),
        }
    }
}

/// `Err` with why unless `weights` holds `n` values, each finite and ≥ 0.
fn check_weights(weights: &[f64], n: usize) -> Result<(), String> {
    if weights.len() != n {
        return Err(format!("{} weights returned for {n} pairs", weights.len()));
    }
    match weights
        .iter()
        .enumerate()
        .find(|(_, w)| !(w.is_finite() && **w >= 0.0))
    {
        Some((pair, w)) => Err(format!(
            "weight {pair} is {w}: weights must be finite and >= 0"
        )),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::variants::builtin;
    use crate::{Registrar, Scan};
    use nalgebra::{Isometry2, Vector2};

    /// IR_ICP's weights (`1 / (r₀ + mean range)`, `r₀ = 1 m`) a batch at a time, failing at
    /// step `fail_at`, or with weight 3 set to `bad`, when given.
    struct Batch {
        fail_at: Option<usize>,
        bad: Option<f64>,
    }

    impl BatchWeighting for Batch {
        fn spec(&self) -> StageSpec {
            StageSpec::kind("test:batch")
        }

        fn weigh_batch(
            &self,
            set: &PairSet<'_>,
            iteration: usize,
            out: &mut Vec<f64>,
        ) -> Result<(), String> {
            if self.fail_at == Some(iteration) {
                return Err("told to".into());
            }
            out.clear();
            out.extend(
                set.pairs
                    .iter()
                    .map(|c| 1.0 / (1.0 + 0.5 * (set.src[c.src].range_m + set.dst[c.dst].range_m))),
            );
            if let Some(bad) = self.bad {
                out[3] = bad;
            }
            Ok(())
        }
    }

    /// Walls around the origin, and the same seen after a small motion.
    fn pair() -> (Scan, Scan) {
        let pts: Vec<[f64; 2]> = (0..150)
            .map(|i| {
                let s = i as f64 * 0.2;
                match i % 3 {
                    0 => [10.0, -5.0 + s * 0.5],
                    1 => [-3.0 + s * 0.4, 8.0],
                    _ => [-3.0 + s * 0.3, -7.0 - s * 0.2],
                }
            })
            .collect();
        let t = Isometry2::new(Vector2::new(-0.3, 0.05), 0.01);
        let moved: Vec<[f64; 2]> = pts
            .iter()
            .map(|p| {
                let q = t * nalgebra::Point2::new(p[0], p[1]);
                [q.x, q.y]
            })
            .collect();
        (
            Scan::from_cartesian(&pts).unwrap(),
            Scan::from_cartesian(&moved).unwrap(),
        )
    }

    /// A batch scheme gives the same registration, bit for bit, as the registered scheme of
    /// the same weights.
    #[test]
    fn a_batch_scheme_matches_the_registered_one() {
        let (src, dst) = pair();
        let spec = builtin("IR_ICP").unwrap();
        assert_eq!(spec.weighting.params["r0_m"], 1.0);
        let rust = spec.build().unwrap();
        let batch = spec.build().unwrap().with_batch_weighting(Batch {
            fail_at: None,
            bad: None,
        });
        let a = rust.register(&src, &dst, Isometry2::identity()).unwrap();
        let b = batch.register(&src, &dst, Isometry2::identity()).unwrap();
        assert_eq!(a, b);
        assert_eq!(batch.spec().weighting.kind, "test:batch");
    }

    #[test]
    fn a_failure_or_a_bad_weight_stops_the_registration_naming_the_iteration() {
        let (src, dst) = pair();
        let run = |b: Batch| {
            builtin("H_ICP")
                .unwrap()
                .build()
                .unwrap()
                .with_batch_weighting(b)
                .register(&src, &dst, Isometry2::identity())
                .unwrap_err()
                .to_string()
        };
        assert_eq!(
            run(Batch {
                fail_at: Some(2),
                bad: None
            }),
            "the pair weighting failed at iteration 2: told to"
        );
        for (bad, shown) in [(f64::NAN, "NaN"), (-1.0, "-1"), (f64::INFINITY, "inf")] {
            assert_eq!(
                run(Batch {
                    fail_at: None,
                    bad: Some(bad)
                }),
                format!(
                    "the pair weighting failed at iteration 0: weight 3 is {shown}: \
                     weights must be finite and >= 0"
                )
            );
        }
        assert_eq!(
            check_weights(&[1.0], 2).unwrap_err(),
            "1 weights returned for 2 pairs"
        );
        assert_eq!(check_weights(&[0.0, 2.0], 2), Ok(()));
    }
}
