//! The extended covariance against a Monte-Carlo on the rough harbour: over 200 draws of the
//! harbour (its piers and hulls, the waves' phases, every error source's draws), HD_PL_ICP
//! registers the first pair from the identity, its error is measured against the exact truth,
//! and the NEES of the covariances is checked against χ²(3).
//!
//! Measured (this test prints them): with every source, the closed form gives ANEES/3 3.19
//! (56 % inside the 95 % interval), the extended covariance 2.00 (78 %); without motion
//! distortion 1.10 (95 %) and 0.87 (96 %); without the boats 2.38 (82 %) and 1.38 (90 %). The
//! jackknife over sectors sees the boats and the heavy tails; the distortion of a revolution
//! that is not deskewed moves every sector alike, which no per-pair estimate sees: that gap is
//! left, and pinned here so that a fix (deskewing, or a term for it) shows.

use datasets::synthetic::{generate, Scenario};
use eval::measure::consistency::nees;
use eval::run::covariance::pose_error;
use eval::run::extended::extended;
use icp_core::variants::builtin;
use icp_core::Registrar;
use nalgebra::Isometry2;

/// ANEES/3 and the fraction inside χ²(3)'s 95 % interval of the closed form's and the
/// extended covariance's NEES of HD_PL_ICP's first pair over 200 seeds of `scenario`.
fn monte_carlo(scenario: &Scenario) -> [(f64, f64); 2] {
    let reg = builtin("HD_PL_ICP").unwrap().build().unwrap();
    let (mut closed, mut ext) = (Vec::new(), Vec::new());
    for seed in 0..200u64 {
        let ds = generate(&Scenario {
            n_scans: 2,
            seed,
            ..scenario.clone()
        })
        .unwrap();
        let r = ds.reference.as_ref().unwrap();
        let truth = (r[0].scan_pose().unwrap().inverse() * r[1].scan_pose().unwrap()).inverse();
        let out = reg
            .register(&ds.scans[0], &ds.scans[1], Isometry2::identity())
            .unwrap();
        let e = pose_error(&out.t_ref_src, &truth);
        let (Some(c), Some(x)) = (
            out.covariance.and_then(|c| c.bounded().copied()),
            extended(&out, 1.0).and_then(|c| c.bounded().copied()),
        ) else {
            continue;
        };
        closed.push(nees(&e, &c).unwrap());
        ext.push(nees(&e, &x).unwrap());
    }
    assert!(closed.len() >= 190, "{} bounded", closed.len());
    let figures = |nees: &[f64]| {
        let inside = nees
            .iter()
            .filter(|&&e| (0.2158..=9.3484).contains(&e))
            .count();
        (
            nees.iter().sum::<f64>() / nees.len() as f64 / 3.0,
            inside as f64 / nees.len() as f64,
        )
    };
    let out = [figures(&closed), figures(&ext)];
    eprintln!(
        "{}: closed form ANEES/3 {:.3}, {:.3} inside; extended ANEES/3 {:.3}, {:.3} inside",
        scenario.name, out[0].0, out[0].1, out[1].0, out[1].1
    );
    out
}

/// Every source but motion distortion: the extended covariance holds (the interval
/// and share), and the jackknife does not make it needlessly wide (ANEES/3 ≥ 0.7).
#[test]
fn extended_covariance_holds_in_the_rough_harbour_without_motion_distortion() {
    let mut scenario = Scenario::rough();
    scenario.scanner.motion_distortion = false;
    let [_, (anees, inside)] = monte_carlo(&scenario);
    assert!((0.7..=1.4).contains(&anees), "{anees}");
    assert!(inside >= 0.88, "{inside}");
}

/// Every source: the nominal model's closed form is over-confident, and the extended
/// covariance is too, less so: the known gap of the module documentation.
#[test]
fn with_motion_distortion_a_gap_remains() {
    let [(closed, _), (anees, _)] = monte_carlo(&Scenario::rough());
    assert!(closed > 2.0, "{closed}");
    assert!(anees > 1.4 && anees < closed, "{anees}");
}
