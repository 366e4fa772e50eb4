//! The motion term of the extended covariance: what the scanner's change of velocity between
//! two scans does to their registration when its returns are taken along a sweep.
//!
//! A scanner whose sweep lasts `T` takes the return at fraction `u ∈ [0, 1)` of it from where
//! it is `u T` after the scan's pose, and the scan places it as if seen from that pose: the
//! return is displaced by the motion over `u T`. Two scans of the same scene, moving at the
//! same velocity, are displaced alike (the same bearing is seen at the same `u`) and the
//! displacement cancels in their relative pose; what is left is the change of velocity `Δv`
//! between the two sweeps, which moves the return at `u` by `u T Δv` relative to the other
//! scan. Over returns spread evenly along the sweep the least-squares pose moves by the mean,
//! `½ T Δv` (a change of turn rate turns it by `½ T Δω` about the scanner). The registration
//! cannot see it: every sector of the scan moves alike, so neither its residuals nor its
//! jackknife show it. The term is its covariance,
//!
//! ```text
//! C_motion = (T² / 4) · mean_j Δv_j Δv_jᵀ,
//! ```
//!
//! `Δv_j = (v_{j+1} − v_{j−1}) / 2` the change of velocity across pair `j` from its two
//! neighbours' registrations (`v` the body velocity `(vx m/s, vy m/s, ω rad/s)` of a pair's
//! motion over its `dt`), averaged over the pairs within [`WINDOW_PAIRS`] of pair `i` whose
//! `Δv` does not use pair `i`'s own registration (`j = i` and `2 ≤ |j − i|`): the pair's own
//! error never widens its own covariance. The neighbours' registration noise enters `Δv` too
//! (the term is then a little wider than the motion alone makes it).
//!
//! `T` is the dataset's [`datasets::Dataset::sweep_s`]: without it (marina and CARMEN do not
//! state it; a ROS 2 bag does through `LaserScan.time_increment` when its driver fills it, and a
//! CSV directory's `dataset.json` may) there is no term; a dataset whose returns are instantaneous (the synthetic
//! `paper` and `marina-like` scenarios) has none either. Chosen on the rough harbour, where the
//! error of the registrations against the truth regresses on the true `Δv` with coefficients
//! −0.5 to −0.6 along the diagonal, as the derivation says.

use datasets::ScanPair;
use nalgebra::{Matrix3, Vector3};

use crate::run::runner::PairRun;
use crate::run::status::PairStatus;

/// Pairs on either side of a pair whose changes of velocity enter its term: ±1 s at the
/// rough harbour's 0.2 s, short against its waves' 3.7–6.7 s periods.
pub const WINDOW_PAIRS: usize = 5;

/// The body velocity `(vx m/s, vy m/s, ω rad/s)` of a registration over its pair's `dt_s`,
/// when the registration is ok.
fn velocity(run: &PairRun, dt_s: f64) -> Option<Vector3<f64>> {
    if run.status != PairStatus::Ok || dt_s.is_nan() || dt_s <= 0.0 {
        return None;
    }
    let motion = run.result.as_ref().ok()?.t_ref_src.inverse();
    let v = motion.translation.vector / dt_s;
    Some(Vector3::new(v.x, v.y, motion.rotation.angle() / dt_s))
}

/// The motion term of every pair of a variant's `runs` (the module documentation), pair `i`
/// of `pairs` taken over `dts_s[i]` seconds, for a sweep of `sweep_s` seconds; `None` where
/// no neighbour gives a change of velocity, and everywhere without a sweep.
pub fn motion_terms(
    sweep_s: Option<f64>,
    pairs: &[ScanPair],
    dts_s: &[f64],
    runs: &[PairRun],
) -> Vec<Option<Matrix3<f64>>> {
    let n = pairs.len();
    let Some(sweep_s) = sweep_s.filter(|s| *s > 0.0) else {
        return vec![None; n];
    };
    let velocities: Vec<Option<Vector3<f64>>> = runs
        .iter()
        .zip(dts_s)
        .map(|(run, dt)| velocity(run, *dt))
        .collect();
    // Δv across pair j, from pairs j − 1 and j + 1 when the three follow one another.
    let change: Vec<Option<Vector3<f64>>> = (0..n)
        .map(|j| {
            let (before, after) = (j.checked_sub(1)?, j + 1);
            let chained = after < n
                && pairs[before].reference == pairs[j].source
                && pairs[j].reference == pairs[after].source;
            chained.then_some(())?;
            Some((velocities[after]? - velocities[before]?) / 2.0)
        })
        .collect();
    (0..n)
        .map(|i| {
            let window = i.saturating_sub(WINDOW_PAIRS)..(i + WINDOW_PAIRS + 1).min(n);
            let (sum, count) = window
                .filter(|&j| j == i || j.abs_diff(i) >= 2)
                .filter_map(|j| change[j])
                .fold((Matrix3::zeros(), 0usize), |(sum, count), dv| {
                    (sum + dv * dv.transpose(), count + 1)
                });
            (count > 0).then(|| sum * (sweep_s * sweep_s / 4.0 / count as f64))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Isometry2, Vector2};

    const DT_S: f64 = 0.2;
    const SWEEP_S: f64 = 0.2;

    /// An ok registration of a scanner moving at body velocity `v` over `DT_S`.
    fn moving(v: Vector3<f64>) -> PairRun {
        let motion = Isometry2::new(Vector2::new(v.x, v.y) * DT_S, v.z * DT_S);
        PairRun::ok_for_test(motion.inverse(), None)
    }

    fn chain(n: usize) -> Vec<ScanPair> {
        (0..n)
            .map(|k| ScanPair {
                source: k,
                reference: k + 1,
            })
            .collect()
    }

    fn terms(runs: &[PairRun], sweep_s: Option<f64>) -> Vec<Option<Matrix3<f64>>> {
        let pairs = chain(runs.len());
        motion_terms(sweep_s, &pairs, &vec![DT_S; runs.len()], runs)
    }

    #[test]
    fn no_sweep_or_an_instant_one_gives_no_term_and_a_steady_velocity_a_zero_one() {
        let runs: Vec<PairRun> = (0..12)
            .map(|_| moving(Vector3::new(1.2, -0.1, 0.05)))
            .collect();
        assert!(terms(&runs, None).iter().all(Option::is_none));
        assert!(terms(&runs, Some(0.0)).iter().all(Option::is_none));
        for term in terms(&runs, Some(SWEEP_S)) {
            assert!(term.unwrap().norm() < 1e-24, "{term:?}");
        }
    }

    #[test]
    fn a_change_of_velocity_gives_a_quarter_of_its_square_times_the_sweep_squared() {
        // Surge 1.0 m/s up to pair 5, 1.2 m/s from pair 6: Δv = 0.1 m/s across pairs 5 and 6.
        let runs: Vec<PairRun> = (0..12)
            .map(|j| moving(Vector3::new(if j < 6 { 1.0 } else { 1.2 }, 0.0, 0.0)))
            .collect();
        let got = terms(&runs, Some(SWEEP_S));
        // Pair 9's window: 4..=7 and 9 (10 and 8 use pair 9's own registration, 11 has no
        // Δv); the changes are 0.1 at 5 and 6, zero at the other three.
        let want = SWEEP_S * SWEEP_S / 4.0 * (2.0 * 0.1 * 0.1) / 5.0;
        let c = got[9].unwrap();
        assert!((c[(0, 0)] - want).abs() < 1e-12 * want, "{c}");
        assert!(c[(1, 1)].abs() < 1e-20 && c[(2, 2)].abs() < 1e-20, "{c}");
        // Pair 0 has no j − 1 neighbour for its own change, and pair 1's is zero.
        assert!(got[0].unwrap()[(0, 0)] > 0.0);
    }

    #[test]
    fn a_pair_s_own_registration_never_enters_its_term() {
        let steady = |j: usize| moving(Vector3::new(1.0, 0.1 * (j as f64).sin(), 0.02));
        let mut runs: Vec<PairRun> = (0..15).map(steady).collect();
        let before = terms(&runs, Some(SWEEP_S));
        runs[7] = moving(Vector3::new(3.0, 2.0, 0.5)); // a wild registration of pair 7
        let after = terms(&runs, Some(SWEEP_S));
        assert_eq!(before[7], after[7]);
        assert_ne!(before[8], after[8]);
        // A neighbour not ok gives no velocity: its changes are left out, not taken as zero.
        runs[7].status = PairStatus::NoOverlap { overlap: 0.0 };
        let failed = terms(&runs, Some(SWEEP_S));
        assert_eq!(failed[7], before[7]);
        assert!(failed.iter().all(Option::is_some));
    }
}
