//! Steps a chain does not trust, predicted from the trusted steps on either side. Where the
//! hulls split a consecutive pair's evidence (`dynamic`) and no bridge carries the chain over
//! it, the scans beyond are still where the vessel's motion just before and just after puts
//! them: a run of at most [`MAX_UNTRUSTED_STEPS`] such steps between two trusted ones is
//! predicted as the mean of those two, each step with the spread that prediction has over the
//! sequence's own trusted windows of the same shape. No motion model and no parameter: the
//! sequence says how well its steps predict each other, and where they do not (a robot that
//! stops and turns between scans) the prediction is not made.

use nalgebra::{Isometry2, Matrix3, Vector2, Vector3};

use super::chain::{Bridges, Step};

/// The most untrusted consecutive steps a bridge spans or a prediction fills: lags up to 3, as
/// the sequence smoother registers by default. Not tuned on data.
pub const MAX_UNTRUSTED_STEPS: usize = 2;

/// The fewest trusted windows whose spread sets a prediction's covariance. The spread is a
/// median absolute deviation, whose relative standard error is about 1.17/√n: 26 % at 20.
const MIN_WINDOWS: usize = 20;

/// `steps` (scan `i` onto `i + 1`; `None`: not trusted) with the untrusted steps that
/// `may_predict` allows and no bridge spans predicted, where they form a run of at most
/// [`MAX_UNTRUSTED_STEPS`] between two trusted steps: each the mean of those two, in
/// `(tx, ty, θ)` (steps of a few decimetres and degrees, where the parameters add), with a
/// diagonal covariance, `g`'s runs' spread ([`run_spread`]) over `g` for a run of `g` steps, so
/// that a chain through the whole run carries the spread of its sum (the steps share one
/// prediction). Runs of a length whose prediction turns the scan by more than
/// `max_rotation_sd_rad` (one standard deviation) are not predicted: a detection's window
/// covers its bearings' noise, not a neighbour turned by more, and a ray that slips past a
/// surface's edge looks through it.
pub fn predicted(
    steps: &[Option<Step>],
    bridges: &Bridges,
    may_predict: impl Fn(usize) -> bool,
    max_rotation_sd_rad: f64,
) -> Vec<Option<Step>> {
    let spanned = |i: usize| bridges.iter().any(|(&a, &(c, _))| a <= i && i < c);
    let mut out = steps.to_vec();
    for g in 1..=MAX_UNTRUSTED_STEPS {
        let Some(spread) = run_spread(steps, g) else {
            continue;
        };
        // A NaN spread (a NaN step) predicts nothing either.
        let turns = spread.z.sqrt();
        if turns.is_nan() || turns > max_rotation_sd_rad {
            continue;
        }
        let covariance = Matrix3::from_diagonal(&(spread / g as f64));
        for a in 1..steps.len().saturating_sub(g) {
            let (Some(before), Some(after)) = (&steps[a - 1], &steps[a + g]) else {
                continue;
            };
            if !(a..a + g).all(|i| steps[i].is_none() && may_predict(i) && !spanned(i)) {
                continue;
            }
            let mean = (twist(before) + twist(after)) / 2.0;
            let t = Isometry2::new(Vector2::new(mean.x, mean.y), mean.z);
            out[a..a + g].fill(Some((t, covariance)));
        }
    }
    out
}

/// The spread of a prediction of `g` consecutive steps from the trusted steps on either side:
/// over every window of `g + 2` trusted steps, the sum of the middle `g` less `g` times the
/// mean of the outer two, per axis `median² + (1.4826 · MAD)²` (a second moment that a few
/// sudden turns do not set). `None` below [`MIN_WINDOWS`] windows.
pub fn run_spread(steps: &[Option<Step>], g: usize) -> Option<Vector3<f64>> {
    let mut residuals: [Vec<f64>; 3] = Default::default();
    for w in steps.windows(g + 2) {
        if !w.iter().all(Option::is_some) {
            continue;
        }
        let at = |j: usize| w[j].as_ref().map_or_else(Vector3::zeros, twist);
        let sum: Vector3<f64> = (1..=g).map(at).sum();
        let r = sum - (at(0) + at(g + 1)) * (g as f64 / 2.0);
        for (axis, values) in residuals.iter_mut().enumerate() {
            values.push(r[axis]);
        }
    }
    if residuals[0].len() < MIN_WINDOWS {
        return None;
    }
    let mut spread = Vector3::zeros();
    for (axis, values) in residuals.iter_mut().enumerate() {
        let centre = median(values);
        let mut deviations: Vec<f64> = values.iter().map(|v| (v - centre).abs()).collect();
        spread[axis] = centre.powi(2) + (1.4826 * median(&mut deviations)).powi(2);
    }
    Some(spread)
}

/// A step's parameters `(tx m, ty m, θ rad)`.
fn twist(step: &Step) -> Vector3<f64> {
    let t = &step.0;
    Vector3::new(t.translation.x, t.translation.y, t.rotation.angle())
}

/// The median of `values` (the upper one of an even count), reordering them.
fn median(values: &mut [f64]) -> f64 {
    let mid = values.len() / 2;
    *values.select_nth_unstable_by(mid, f64::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    const SD: [f64; 3] = [0.02, 0.01, 0.002];

    /// Steps of a constant motion with independent noise of `SD` per axis.
    fn noisy_steps(n: usize, seed: u64) -> Vec<Option<Step>> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut draw = |sd: f64| sd * rng.sample::<f64, _>(StandardNormal);
        (0..n)
            .map(|_| {
                let (x, y, th) = (0.24 + draw(SD[0]), draw(SD[1]), 0.001 + draw(SD[2]));
                Some((Isometry2::new(Vector2::new(x, y), th), Matrix3::zeros()))
            })
            .collect()
    }

    /// With independent noise of variance σ² per step, a run of `g` steps less `g` times the
    /// mean of its neighbours has variance (g + g²/2)·σ², and each predicted step carries that
    /// over `g`; a prediction's actual error has the same variance.
    #[test]
    fn spread_matches_independent_noise() {
        let steps = noisy_steps(4000, 3);
        for g in 1..=2 {
            let spread = run_spread(&steps, g).unwrap();
            let factor = g as f64 + (g * g) as f64 / 2.0;
            for axis in 0..3 {
                let expected = factor * SD[axis].powi(2);
                let ratio = spread[axis] / expected;
                // The MAD's sampling error over ≈ 4000 overlapping windows is a few per cent.
                assert!((ratio - 1.0).abs() < 0.1, "g {g} axis {axis}: ×{ratio}");
            }
        }
    }

    /// Each untrusted step between trusted ones is predicted as their mean, with the spread
    /// of its run's length; a chain through the run carries the run's spread.
    #[test]
    fn a_run_between_trusted_steps_is_their_mean() {
        let mut steps = noisy_steps(200, 5);
        let (before, after) = (steps[49].unwrap(), steps[52].unwrap());
        steps[50] = None;
        steps[51] = None;
        steps[100] = None;
        let out = predicted(&steps, &Bridges::new(), |_| true, 1.0);
        let mean = (twist(&before) + twist(&after)) / 2.0;
        for i in [50, 51] {
            let (t, c) = out[i].unwrap();
            assert!((twist(&(t, c)) - mean).norm() < 1e-15);
            let spread = run_spread(&steps, 2).unwrap();
            assert_eq!(c, Matrix3::from_diagonal(&(spread / 2.0)));
        }
        let (t, c) = out[100].unwrap();
        let single = (twist(&steps[99].unwrap()) + twist(&steps[101].unwrap())) / 2.0;
        assert!((twist(&(t, c)) - single).norm() < 1e-15);
        assert_eq!(c, Matrix3::from_diagonal(&run_spread(&steps, 1).unwrap()));
        // The trusted steps are as they were.
        assert_eq!(out[49], steps[49]);
        assert_eq!(out[52], steps[52]);
    }

    /// Not predicted: a step the caller does not allow, one a bridge spans, a run longer than
    /// [`MAX_UNTRUSTED_STEPS`], a run at either end (no trusted step beyond it), a sequence
    /// whose steps turn it more than the bound allows, or too short to say how well its steps
    /// predict each other.
    #[test]
    fn what_is_not_predicted() {
        let mut steps = noisy_steps(200, 7);
        for i in [0, 20, 40, 60, 61, 62, 199] {
            steps[i] = None;
        }
        let bridge = (steps[39].unwrap().0, Matrix3::zeros());
        let bridges = Bridges::from([(40, (42, bridge))]);
        let out = predicted(&steps, &bridges, |i| i != 20, 1.0);
        for i in [0, 20, 40, 60, 61, 62, 199] {
            assert!(out[i].is_none(), "step {i} predicted");
        }
        // The same without the refusal and the bridge: both predicted.
        let out = predicted(&steps, &Bridges::new(), |_| true, 1.0);
        assert!(out[20].is_some() && out[40].is_some());
        // The bound on the rotation's standard deviation, just below and just above it.
        let turn_sd = run_spread(&steps, 1).unwrap().z.sqrt();
        assert!(predicted(&steps, &Bridges::new(), |_| true, 0.99 * turn_sd)[20].is_none());
        assert!(predicted(&steps, &Bridges::new(), |_| true, 1.01 * turn_sd)[20].is_some());
        // 20 steps with a hole leave 15 windows of three trusted steps; 30 leave 25.
        let mut short = steps[100..120].to_vec();
        short[5] = None;
        assert!(predicted(&short, &Bridges::new(), |_| true, 1.0)[5].is_none());
        let mut long = steps[100..130].to_vec();
        long[5] = None;
        assert!(predicted(&long, &Bridges::new(), |_| true, 1.0)[5].is_some());
    }

    /// Over many draws, a predicted step's error against the step it stands for is inside its
    /// covariance as often as a Gaussian's (NEES over 3 axes near 3).
    #[test]
    fn predicted_covariance_holds() {
        let truth = noisy_steps(3000, 11);
        let mut steps = truth.clone();
        let holes: Vec<usize> = (10..2990).step_by(7).collect();
        for &i in &holes {
            steps[i] = None;
        }
        let out = predicted(&steps, &Bridges::new(), |_| true, 1.0);
        let nees: f64 = holes
            .iter()
            .map(|&i| {
                let (t, c) = out[i].unwrap();
                let e = twist(&(t, c)) - twist(&truth[i].unwrap());
                (e.transpose() * c.try_inverse().unwrap() * e)[(0, 0)]
            })
            .sum::<f64>()
            / holes.len() as f64;
        assert!((nees / 3.0 - 1.0).abs() < 0.15, "ANEES/3 {}", nees / 3.0);
    }
}
