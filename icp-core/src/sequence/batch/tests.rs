//! The batch solve's chord step.

use super::super::fixtures::{weaving_model, weaving_run};
use super::super::{initial_estimates, Geometry};
use super::*;

/// `H x` for the H whose upper triangle `values` holds, in the pattern of `sys`.
fn h_times(sys: &SparseSystem, values: &[f64], x: &[f64]) -> Vec<f64> {
    let (col_ptr, row_idx) = (sys.mat.symbolic().col_ptr(), sys.mat.symbolic().row_idx());
    let mut y = vec![0.0; x.len()];
    for j in 0..x.len() {
        for at in col_ptr[j]..col_ptr[j + 1] {
            let (i, v) = (row_idx[at], values[at]);
            y[i] += v * x[j];
            if i != j {
                y[j] += v * x[i];
            }
        }
    }
    y
}

/// `|H x + g| / |g|`: how far `x` is from solving `H x = −g`.
fn relative_residual(sys: &SparseSystem, values: &[f64], x: &[f64], g: &[f64]) -> f64 {
    let hx = h_times(sys, values, x);
    let residual: f64 = hx.iter().zip(g).map(|(a, b)| (a + b).powi(2)).sum();
    let gradient: f64 = g.iter().map(|e| e * e).sum();
    (residual / gradient).sqrt()
}

/// The weaving run's model, layout and system, and its chained start: `test` is given them and
/// the number of scans.
fn with_weaving_system(
    test: impl FnOnce(&Model<'_>, &Layout, &mut SparseSystem, Estimates, usize),
) {
    let (times_s, regs) = weaving_run();
    let model = weaving_model(&times_s, &regs, [0.05, 0.01, 0.01]);
    let n = times_s.len();
    let layout = model.layout(0, n);
    let mut sys = SparseSystem::new(&model, &layout, n).unwrap();
    let est = initial_estimates(Geometry::Se2, &times_s, &regs);
    test(&model, &layout, &mut sys, est, n);
}

/// The solve on the last factor is the Newton step right after a factorisation, and a
/// chord step `−H₀⁻¹g` once the system was linearised again: H₀ the system factorised, g
/// the gradient now. The chord is taken only within the tolerance.
#[test]
fn a_chord_step_solves_the_factorised_system_with_the_gradient_now() {
    with_weaving_system(|model, layout, sys, mut est, _| {
        linearise(model, &est, layout, sys);
        let h0 = sys.mat.val().to_vec();
        let newton = sys.step().unwrap();
        assert!(relative_residual(sys, &h0, &newton, &sys.g) < 1e-10);
        assert_eq!(sys.step_on_last_factor(), newton);

        layout.apply(Geometry::Se2, &mut est, &newton, 1.0);
        linearise(model, &est, layout, sys);
        let moved = relative_residual(sys, sys.mat.val(), &newton, &sys.g);
        assert!(moved > 1e-3, "the system did not change: {moved}");
        let chord = sys.step_on_last_factor();
        assert!(relative_residual(sys, &h0, &chord, &sys.g) < 1e-10);
        // Not the Newton step of the system now.
        assert!(relative_residual(sys, sys.mat.val(), &chord, &sys.g) > 1e-6);

        let d = decrement(&sys.g, &chord).unwrap();
        assert!(d > 0.0);
        assert_eq!(chord_step(sys, d).unwrap(), Some(chord));
        assert_eq!(chord_step(sys, 0.5 * d).unwrap(), None);
    });
}

/// A solve that a chord step ended is converged as a Newton step at its result says, and
/// the marginals from the factor it kept (the system before that step's) are those of the
/// system at the result.
#[test]
fn a_solve_a_chord_step_ended_is_within_its_tolerance() {
    with_weaving_system(|model, layout, sys, mut est, n| {
        let tolerance = 1e-4;
        let (_, stop) = solve(model, &mut est, sys, layout, 100, tolerance).unwrap();
        assert_eq!(stop, SolveStop::Converged);
        // The factor kept is not the system last linearised: a chord step ended the solve.
        let kept = sys.step_on_last_factor();
        assert!(relative_residual(sys, sys.mat.val(), &kept, &sys.g) > 1e-6);
        let kept_marginals = marginals(sys, layout, n).unwrap();

        linearise(model, &est, layout, sys);
        let newton = sys.step().unwrap();
        let newton_decrement = decrement(&sys.g, &newton).unwrap();
        assert!(
            newton_decrement <= tolerance,
            "a Newton step at the result: {newton_decrement}"
        );
        let fresh = marginals(sys, layout, n).unwrap();
        let mut worst = 0.0_f64;
        for (a, b) in kept_marginals.own.iter().zip(&fresh.own) {
            for i in 0..6 {
                if b[(i, i)] > 0.0 {
                    worst = worst.max((a[(i, i)] / b[(i, i)] - 1.0).abs());
                }
            }
        }
        // Three digits, as the estimation of `Qc` reads them (2.4e-5 here).
        assert!(worst < 1e-3, "{worst}");
    });
}
