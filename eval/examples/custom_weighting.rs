//! Try a new pair-weighting scheme without touching the library: implement `PairWeighting`
//! here, put it in H_ICP's chain, and compare it with HD_ICP on the same pairs, with a
//! bootstrap interval and a Wilcoxon test.
//!
//!   cargo run --release -p eval --example custom_weighting
//!
//! The scheme below trusts a pair by how well its two returns agree in range: returns of the
//! same surface seen from two close poses have similar ranges, spurious ones do not.

use datasets::synthetic::{generate, Scenario};
use eval::measure::compare::compare;
use eval::measure::compare::CompareOptions;
use eval::pipeline::evaluate;
use eval::render::markdown::compare::compare_md;
use eval::run::setup::EvalSetup;
use eval::run::setup::OffsetChoice;
use eval::run::setup::ReferenceChecks;
use icp_core::variants::builtin;
use icp_core::weighting::{PairView, PairWeighting};
use indicatif::ProgressBar;

/// `w = 1 / (s + |r_k − r_k+1|)`, s in metres.
struct RangeAgreement {
    softening_m: f64,
}

impl PairWeighting for RangeAgreement {
    fn weight(&self, pair: &PairView<'_>) -> f64 {
        1.0 / (self.softening_m + (pair.src.range_m - pair.dst.range_m).abs())
    }
}

fn main() -> anyhow::Result<()> {
    let ds = generate(&Scenario::marina_like())?;
    let mine = icp_core::variants::h_icp()
        .with_weighting(RangeAgreement { softening_m: 0.5 })
        .named("RA_ICP");
    // The runner takes any registrar; the report describes each by its own spec, so RA_ICP
    // shows H_ICP's stages with its weighting named by its Rust type.
    let setup = EvalSetup {
        variants: vec![
            Box::new(builtin("HD_ICP").expect("built in").build()?),
            Box::new(mine),
        ],
        offset: OffsetChoice::Fixed(0),
        reference_checks: ReferenceChecks::On,
        init: Default::default(),
        global: Default::default(),
        global_check: Default::default(),
        start_gate: Default::default(),
        covariance: Default::default(),
        estimates: Vec::new(),
        lags: 1,
        sequence: Default::default(),
    };
    let report = evaluate(&ds, &setup, &ProgressBar::hidden())?;
    for (v, spec) in report.variants.iter().zip(&report.config.variants) {
        let e = v.plausible_reference.sog_err_mps.expect("registered pairs");
        println!(
            "{:7} SOG error std {:.4} m/s, median |e| {:.4} m/s (weighting: {})",
            v.name, e.std, e.median_abs, spec.weighting
        );
    }
    let options = CompareOptions::default();
    println!(
        "\n{}",
        compare_md(&report, &compare(&report, &options), &options)
    );
    Ok(())
}
