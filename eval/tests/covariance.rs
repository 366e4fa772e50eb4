//! The covariance columns of a run: the sampled estimate is the same whatever the thread count,
//! the closed form gives point-to-point variants nothing, an unbounded covariance gives empty
//! cells and a flag, restarts only widen the extended covariance, and no table holds a NaN.

use datasets::synthetic::{generate, Scenario};
use eval::measure::consistency::fill;
use eval::measure::record::PairRecord;
use eval::pipeline::evaluate;
use eval::run::covariance::CovarianceMode;
use eval::run::setup::EvalSetup;
use eval::run::setup::OffsetChoice;
use icp_core::variants::builtin;
use icp_core::{Covariance, Registration, StopReason};
use indicatif::ProgressBar;
use nalgebra::{Isometry2, Vector2, Vector3};

fn setup(mode: CovarianceMode) -> EvalSetup {
    let specs: Vec<_> = ["HD_ICP", "HD_PL_ICP"]
        .iter()
        .map(|n| builtin(n).unwrap())
        .collect();
    EvalSetup::from_specs(&specs, OffsetChoice::Fixed(0))
        .unwrap()
        .with_covariance(mode)
}

fn covariance_cells(r: &PairRecord) -> [Option<f64>; 10] {
    [
        r.cov_xx_m2,
        r.cov_xy_m2,
        r.cov_xt_m_rad,
        r.cov_yy_m2,
        r.cov_yt_m_rad,
        r.cov_tt_rad2,
        r.sog_sigma_mps,
        r.dcog_sigma_deg,
        r.rot_sigma_dps,
        r.nees,
    ]
}

#[test]
fn sampled_is_the_same_whatever_the_thread_count_and_the_closed_form_skips_point_to_point() {
    let ds = generate(&Scenario {
        n_scans: 5,
        ..Scenario::paper()
    })
    .unwrap();
    let run = |threads: usize, mode: CovarianceMode| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| evaluate(&ds, &setup(mode), &ProgressBar::hidden()).unwrap())
    };
    let (one, two) = (
        run(1, CovarianceMode::Sampled),
        run(2, CovarianceMode::Sampled),
    );
    assert_eq!(one.pairs.len(), 8);
    for (a, b) in one.pairs.iter().zip(&two.pairs) {
        assert_eq!(a.cov_status, "bounded", "{} pair {}", a.variant, a.pair);
        // Bit-identical, every variant (point-to-point included) has one.
        assert_eq!(covariance_cells(a), covariance_cells(b));
        assert!(a.nees.is_some_and(f64::is_finite));
    }
    let closed = run(2, CovarianceMode::ClosedForm);
    for r in &closed.pairs {
        let has = r.variant == "HD_PL_ICP";
        assert_eq!(r.cov_status, if has { "bounded" } else { "" });
        assert_eq!(r.cov_xx_m2.is_some(), has, "{}", r.variant);
    }
    let off = run(2, CovarianceMode::Off);
    assert!(off
        .pairs
        .iter()
        .all(|r| r.cov_status.is_empty() && covariance_cells(r).iter().all(Option::is_none)));
    assert!(off.variants.iter().all(|v| v.consistency.is_none()));
    for report in [&one, &closed] {
        let csv = String::from_utf8(eval::render::csv::pairs_csv(report).unwrap()).unwrap();
        assert!(!csv.to_lowercase().contains("nan"), "{csv}");
        assert!(csv.lines().next().unwrap().contains(
            "cov_xx_m2,cov_xy_m2,cov_xt_m_rad,cov_yy_m2,cov_yt_m_rad,cov_tt_rad2,sog_sigma_mps,\
             dcog_sigma_deg,rot_sigma_dps,nees"
        ));
        let md = eval::render::markdown::table_md(report);
        assert!(md.contains("## Covariance consistency") && !md.contains("NaN"));
    }
}

#[test]
fn an_unbounded_covariance_gives_empty_cells_and_a_flag() {
    let mut row: PairRecord = serde_json::from_value(serde_json::json!({
        "variant": "HD_PL_ICP", "pair": 0, "source": 0, "reference": 1, "dt_s": 0.2,
        "status": "degenerate", "status_reason": "", "all_registered": true, "init": "identity",
        "init_attempts": 1, "converged": true, "iterations": 3, "n_pairs": 100,
        "n_unusable": 0, "ref_plausible": true, "time_us": 1.0
    }))
    .unwrap();
    let mut reg = Registration {
        t_ref_src: Isometry2::new(Vector2::new(0.2, 0.0), 0.0),
        iterations: 3,
        stop: StopReason::Converged,
        n_pairs: 100,
        n_unusable: 0,
        weight_sum: 100.0,
        mean_residual_m: 0.01,
        conditioning: None,
        overlap: 1.0,
        covariance: Some(Covariance::Unbounded {
            direction: Vector3::x(),
            condition: f64::INFINITY,
        }),
        jackknife_covariance: None,
    };
    let truth = Some(Isometry2::identity());
    fill(
        &mut row,
        Some(&reg),
        truth,
        CovarianceMode::ClosedForm,
        1.0,
        None,
    );
    assert_eq!(row.cov_status, "unbounded");
    assert!(covariance_cells(&row).iter().all(Option::is_none));
    // A bounded one fills every cell; the NEES of e = (0.2, 0, 0) under 0.01·I is 4.
    reg.covariance = Some(Covariance::Bounded(nalgebra::Matrix3::identity() * 0.01));
    fill(
        &mut row,
        Some(&reg),
        truth,
        CovarianceMode::ClosedForm,
        1.0,
        None,
    );
    assert_eq!(row.cov_status, "bounded");
    assert!((row.nees.unwrap() - 4.0).abs() < 1e-12);
    assert!((row.sog_sigma_mps.unwrap() - 0.1 / 0.2).abs() < 1e-12);
}

/// The NEES figure is drawn where some pair has a NEES, and its χ²(3) curve is the
/// distribution whose quantiles the consistency figures use.
#[test]
fn the_nees_figure_is_drawn_against_chi2_3() {
    use eval::measure::consistency::chi2_cdf;
    use eval::measure::consistency::chi2_quantile;
    for p in [0.025, 0.5, 0.975] {
        assert!(
            (chi2_cdf(3.0, chi2_quantile(3.0, p)) - p).abs() < 1e-9,
            "{p}"
        );
    }
    // χ²(3) has mean 3; its CDF at 3 is 0.608375 (tables).
    assert!((chi2_cdf(3.0, 3.0) - 0.608_375).abs() < 1e-6);
    let ds = generate(&Scenario {
        n_scans: 6,
        ..Scenario::paper()
    })
    .unwrap();
    let report = evaluate(
        &ds,
        &setup(CovarianceMode::ClosedForm),
        &ProgressBar::hidden(),
    )
    .unwrap();
    assert!(report.pairs.iter().any(|r| r.nees.is_some()));
    let dir = std::env::temp_dir().join(format!("icp-nees-figure-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut out = eval::render::outdir::OutputDir::open(&dir, false).unwrap();
    eval::render::write_outputs(&mut out, &ds, &report, true).unwrap();
    assert!(dir.join("nees.png").is_file() && dir.join("nees.svg").is_file());
    let off = evaluate(&ds, &setup(CovarianceMode::Off), &ProgressBar::hidden()).unwrap();
    assert!(off.pairs.iter().all(|r| r.nees.is_none()));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `restarts` is the extended covariance plus the spread of six re-registrations from
/// perturbed starts (`run::restarts`): on every point-to-line pair it is the extended one
/// plus a positive semi-definite term, not smaller along any direction, and the term is not
/// zero everywhere; a point-to-point variant gets none in either mode.
#[test]
fn restarts_add_a_positive_term_to_the_extended_covariance() {
    let ds = generate(&Scenario {
        n_scans: 8,
        ..Scenario::rough()
    })
    .unwrap();
    let run = |mode| evaluate(&ds, &setup(mode), &ProgressBar::hidden()).unwrap();
    let (extended, restarts) = (run(CovarianceMode::Extended), run(CovarianceMode::Restarts));
    let matrix = |r: &PairRecord| {
        let c = covariance_cells(r);
        c[..6].iter().all(Option::is_some).then(|| {
            let [xx, xy, xt, yy, yt, tt] = [c[0], c[1], c[2], c[3], c[4], c[5]].map(Option::unwrap);
            nalgebra::Matrix3::new(xx, xy, xt, xy, yy, yt, xt, yt, tt)
        })
    };
    let mut widened = 0;
    for (e, r) in extended.pairs.iter().zip(&restarts.pairs) {
        assert_eq!((&e.variant, e.pair), (&r.variant, r.pair));
        if e.variant == "HD_ICP" {
            assert!(matrix(e).is_none() && matrix(r).is_none());
            continue;
        }
        let (Some(ce), Some(cr)) = (matrix(e), matrix(r)) else {
            panic!("pair {} has no covariance", e.pair)
        };
        let term = nalgebra::SymmetricEigen::new(cr - ce).eigenvalues;
        let scale = ce.norm();
        assert!(term.min() >= -1e-9 * scale, "pair {}: {term}", e.pair);
        widened += usize::from(term.max() > 1e-6 * scale);
    }
    assert!(widened > 0, "no pair widened by its restarts");
}
