//! The probe the `free_space` detector's parameters were chosen with (docs/moving-returns.md):
//! its detection in every scan of a labelled dataset from the neighbours at their *true* poses,
//! scored against the labels, so that the detector is judged apart from the registrations.
//!
//! `cargo run --release -p eval --example moving_probe -- 'synthetic:rough?seed=7' '{"lag_scans": 2}'`
//! (the second argument overrides parameters of the defaults).

use datasets::ScanPair;
use icp_core::moving::{
    beside, left_out_points, Bridges, Detection, FreeSpace, MovingReturns, Neighbour, RangeImage,
};
use icp_core::registry::Params;
use nalgebra::{Matrix3, Vector3};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let spec = args.next().unwrap_or("synthetic:rough?seed=7".into());
    let mut params = serde_json::to_value(FreeSpace::default())?;
    if let Some(overrides) = args.next() {
        let overrides: serde_json::Map<String, serde_json::Value> =
            serde_json::from_str(&overrides)?;
        for (k, v) in overrides {
            params[k] = v;
        }
    }
    let detector: FreeSpace = serde_json::from_value(params)?;
    detector.validate()?;
    let ds = datasets::source::open(&spec)?;
    let n = ds.scans.len();
    // The true steps, with a small covariance (1 mm, 0.02°) standing for a good registration.
    let steps: Vec<_> = (0..n.saturating_sub(1))
        .map(|k| {
            let pair = ScanPair {
                source: k,
                reference: k + 1,
            };
            eval::data::motion(&ds, k, k + 1, ds.pair_dt_s(pair))
                .and_then(|m| m.t_ref_src)
                .map(|t| (t, Matrix3::from_diagonal(&Vector3::new(1e-6, 1e-6, 1e-7))))
        })
        .collect();
    let images: Vec<RangeImage> = ds.scans.iter().map(RangeImage::new).collect();
    let detected: Vec<Detection> = (0..n)
        .map(|k| {
            let neighbours =
                Neighbour::placed((&steps, &Bridges::new()), k, detector.lag_scans, |j| {
                    images.get(j)
                });
            detector.detect(&ds.scans[k], &neighbours, &ds.sensor)
        })
        .collect();
    let (mut moving, mut moving_out, mut stat, mut stat_out, mut seen) = (0, 0, 0, 0, 0);
    for k in 0..n {
        let [before, after] = beside(k, &steps, |j, t_k_j| {
            left_out_points(&ds.scans[j], &detected[j], t_k_j)
        });
        let d = detector.fill_between(&ds.scans[k], detected[k].clone(), &before, &after);
        let Some(labels) = ds.scans[k].moving() else {
            anyhow::bail!("{spec} has no moving labels");
        };
        for (&m, &out) in labels.iter().zip(&d.left_out) {
            if m {
                (moving, moving_out) = (moving + 1, moving_out + usize::from(out));
            } else {
                (stat, stat_out) = (stat + 1, stat_out + usize::from(out));
            }
        }
        seen += d.seen;
    }
    let share = |a: usize, b: usize| a as f64 / b.max(1) as f64;
    println!(
        "recall {:.3} ({moving_out} of {moving}), static left out {:.4} ({stat_out} of {stat}), seen to move per scan {:.1}",
        share(moving_out, moving),
        share(stat_out, stat),
        share(seen, n)
    );
    Ok(())
}
