//! How a registration's cost grows with scan size: one variant on pairs of synthetic harbour
//! scans from ever denser scanners, timed, with the iterations it took, so the cost per point
//! and iteration (the matcher's share of the growth) is told apart from the iteration count
//! (the convergence rule's share).

use std::time::Instant;

use datasets::synthetic::{generate, ScannerConfig, Scenario};
use icp_core::variants::VariantSpec;
use icp_core::{IcpError, Registrar};
use nalgebra::Isometry2;

use crate::error::EvalError;
use crate::measure::scaling::{ScalingPoint, ScalingResult};

/// Times the variant `spec` registering scan 0 onto scan 1 of the synthetic `paper` scenario with
/// `beams` returns per revolution, for each entry of `beams`. Each size is repeated until about
/// `budget_s` seconds are spent (at least 3 times).
pub fn measure(
    spec: &VariantSpec,
    beams: &[usize],
    budget_s: f64,
) -> Result<ScalingResult, EvalError> {
    let registrar = spec.build()?;
    let mut points = Vec::with_capacity(beams.len());
    for &n in beams {
        if n == 0 {
            return Err(IcpError::InvalidParameter {
                name: "beams",
                value: 0.0,
                reason: "at least one beam per revolution",
            }
            .into());
        }
        let scenario = Scenario {
            n_scans: 2,
            scanner: ScannerConfig {
                sample_rate_hz: n as f64 * ScannerConfig::default().rotation_hz,
                ..ScannerConfig::default()
            },
            ..Scenario::paper()
        };
        let ds = generate(&scenario)?;
        let (source, reference) = (&ds.scans[0], &ds.scans[1]);
        let mut times = Vec::new();
        let started = Instant::now();
        let reg = loop {
            let t = Instant::now();
            let reg = registrar.register(source, reference, Isometry2::identity())?;
            times.push(t.elapsed().as_secs_f64() * 1e6);
            if times.len() >= 3 && started.elapsed().as_secs_f64() >= budget_s {
                break reg;
            }
        };
        let (median_us, _) = crate::measure::stats::median_p95(&times)
            .unwrap_or_else(|| unreachable!("at least three registrations were timed"));
        points.push(ScalingPoint {
            beams: n,
            returns: source.len(),
            pairs: reg.n_pairs,
            iterations: reg.iterations,
            stop: format!("{:?}", reg.stop),
            median_us,
            repetitions: times.len(),
            ns_per_point_iteration: 1e3 * median_us
                / (reg.n_pairs.max(1) as f64 * (reg.iterations + 1) as f64),
        });
    }
    Ok(ScalingResult {
        variant: spec.name.clone(),
        points,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::markdown::scaling::scaling_md;
    use icp_core::variants::builtin;

    #[test]
    fn sizes_are_measured_in_order_and_zero_beams_is_an_error() {
        let spec = builtin("K_ICP").unwrap();
        let r = measure(&spec, &[60, 200], 0.0).unwrap();
        assert_eq!(r.variant, "K_ICP");
        let beams: Vec<usize> = r.points.iter().map(|p| p.beams).collect();
        assert_eq!(beams, vec![60, 200]);
        assert!(r.points[0].returns < r.points[1].returns);
        for p in &r.points {
            assert!(
                p.repetitions >= 3 && p.iterations >= 1 && p.pairs > 0,
                "{p:?}"
            );
            assert!(p.returns <= p.beams, "{p:?}");
        }
        let md = scaling_md(&r);
        assert_eq!(md.lines().filter(|l| l.starts_with("| 60 |")).count(), 1);
        assert!(matches!(
            measure(&spec, &[0], 0.0),
            Err(EvalError::Icp(IcpError::InvalidParameter {
                name: "beams",
                ..
            }))
        ));
    }
}
