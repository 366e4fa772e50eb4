//! Try a new pair-weighting scheme without touching the library: implement `PairWeighting`
//! here, put it in H_ICP's chain, and compare it with HD_ICP on the same pairs, with a
//! bootstrap interval and a Wilcoxon test.
//!
//!   cargo run --release -p eval --example custom_weighting
//!
//! The scheme below trusts a pair by how well its two returns agree in range: returns of the
//! same surface seen from two close poses have similar ranges, spurious ones do not.

use datasets::synthetic::{generate, Scenario};
use eval::compare::{compare, compare_md, CompareOptions};
use eval::report::{build, EvalSetup, OffsetChoice};
use eval::runner::run_all;
use icp_core::variants::{builtin, VariantConfig};
use icp_core::weighting::{PairView, PairWeighting};
use icp_core::Registrar;
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
    let (pairs, skipped) = ds.consecutive_pairs();
    let hd_spec = builtin("HD_ICP", &VariantConfig::default()).expect("built in");
    let mine = icp_core::variants::h_icp()
        .with_weighting(RangeAgreement { softening_m: 0.5 })
        .named("RA_ICP");
    let registrars: Vec<Box<dyn Registrar>> = vec![hd_spec.build()?, Box::new(mine)];
    let runs = run_all(&ds, &pairs, &registrars, &ProgressBar::hidden());
    // The report only needs specs for its provenance: describe RA_ICP as H_ICP renamed.
    let mut ra_spec = builtin("H_ICP", &VariantConfig::default()).expect("built in");
    ra_spec.name = "RA_ICP".into();
    ra_spec.source = Some(
        "eval/examples/custom_weighting.rs: range-agreement weights (not a built-in stage)".into(),
    );
    let setup = EvalSetup {
        variants: vec![hd_spec, ra_spec],
        offset: OffsetChoice::Fixed(0),
    };
    let report = build(&ds, &pairs, skipped, &setup, &runs);
    for v in &report.variants {
        let e = v.plausible_reference.sog_err_mps.expect("registered pairs");
        println!(
            "{:7} SOG error std {:.4} m/s, median |e| {:.4} m/s",
            v.name, e.std, e.median_abs
        );
    }
    let options = CompareOptions::default();
    println!(
        "\n{}",
        compare_md(&report, &compare(&report, &options), &options)
    );
    Ok(())
}
