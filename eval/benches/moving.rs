//! The cost of the moving-returns stage (`icp_core::moving`, issue 34) on the rough harbour
//! (its first 60 scans after the first boat starts to move, scans 70..130), per pair, beside
//! PL_ICP's registration of the pair from the identity (`register`), for its scale:
//!
//! - `range-image`: one scan's range image (made once per scan and run, shared by the rounds
//!   and the variants);
//! - `detect`: one scan's detection against its 16 neighbours (k−8..k+8) at their true poses
//!   (each image's window minima are made by its first detection of the first iteration and
//!   read after, as in a run, where an image serves 16 scans in each round);
//! - `register-again`: the second registration of the pair without the returns left out,
//!   from the first result, the masked scans' surface estimates included (as the harness does
//!   it, once per scan and round, shared by the scan's two pairs);
//! - `predict`: the untrusted steps of the whole chain (every tenth of its 138 steps) predicted
//!   from the trusted ones on either side (`icp_core::moving::predicted`, once per round and
//!   registrar in a run, over all its steps: not per pair).
//!
//! The stage runs `detect` and `register-again` once per round (two by default) on top of the
//! first registration.
//!
//!   cargo bench -p eval --bench moving

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use datasets::synthetic::{generate, Scenario};
use datasets::ScanPair;
use icp_core::moving::{predicted, Bridges, FreeSpace, MovingReturns, Neighbour, RangeImage};
use icp_core::variants::builtin;
use icp_core::{Prepared, Registrar, Scan, Surfaces, Workspace};
use nalgebra::{Isometry2, Matrix3, Vector3};

/// The scans benchmarked.
const FIRST: usize = 70;
const SCANS: usize = 60;

fn moving(c: &mut Criterion) {
    let ds = generate(&Scenario {
        n_scans: FIRST + SCANS + 9,
        ..Scenario::rough()
    })
    .expect("the rough harbour");
    let n = ds.scans.len();
    let steps: Vec<_> = (0..n - 1)
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
    let detector = FreeSpace::default();
    let pl_icp = builtin("PL_ICP")
        .expect("PL_ICP")
        .build()
        .expect("it builds");
    let params = pl_icp.surface_params();
    let range = FIRST..FIRST + SCANS;
    let detect = |k: usize| {
        let neighbours = Neighbour::placed((&steps, &Bridges::new()), k, detector.lag_scans, |j| {
            images.get(j)
        });
        detector.detect(&ds.scans[k], &neighbours, &ds.sensor)
    };
    let detections: Vec<_> = range.clone().map(detect).collect();
    let surfaces: Vec<Surfaces> = range
        .clone()
        .map(|k| Surfaces::estimate(&ds.scans[k], &params))
        .collect();
    let mut workspace = Workspace::default();
    let firsts: Vec<Isometry2<f64>> = (0..SCANS - 1)
        .map(|i| {
            pl_icp
                .register_prepared(
                    &mut workspace,
                    Prepared::new(&ds.scans[FIRST + i], &surfaces[i]),
                    Prepared::new(&ds.scans[FIRST + i + 1], &surfaces[i + 1]),
                    Isometry2::identity(),
                )
                .map_or(Isometry2::identity(), |r| r.t_ref_src)
        })
        .collect();

    let mut g = c.benchmark_group("moving/rough");
    g.sample_size(10);
    g.throughput(Throughput::Elements((SCANS - 1) as u64));
    g.bench_function("range-image", |b| {
        b.iter(|| {
            range
                .clone()
                .map(|k| RangeImage::new(&ds.scans[k]).spacing_rad())
                .sum::<f64>()
        })
    });
    g.bench_function("detect", |b| {
        b.iter(|| range.clone().map(detect).map(|d| d.count()).sum::<usize>())
    });
    g.bench_function("register", |b| {
        b.iter(|| {
            (0..SCANS - 1)
                .filter(|&i| {
                    pl_icp
                        .register_prepared(
                            &mut workspace,
                            Prepared::new(&ds.scans[FIRST + i], &surfaces[i]),
                            Prepared::new(&ds.scans[FIRST + i + 1], &surfaces[i + 1]),
                            Isometry2::identity(),
                        )
                        .is_ok()
                })
                .count()
        })
    });
    g.bench_function("register-again", |b| {
        b.iter(|| {
            let masked: Vec<(Scan, Surfaces)> = range
                .clone()
                .zip(&detections)
                .map(|(k, d)| {
                    let scan = ds.scans[k].without(&d.left_out);
                    let surfaces = Surfaces::estimate(&scan, &params);
                    (scan, surfaces)
                })
                .collect();
            let prepared = |i: usize| Prepared::new(&masked[i].0, &masked[i].1);
            (0..SCANS - 1)
                .filter(|&i| {
                    pl_icp
                        .register_prepared(&mut workspace, prepared(i), prepared(i + 1), firsts[i])
                        .is_ok()
                })
                .count()
        })
    });
    let holed: Vec<_> = steps
        .iter()
        .enumerate()
        .map(|(i, s)| s.filter(|_| i % 10 != 5))
        .collect();
    g.bench_function("predict", |b| {
        b.iter(|| {
            predicted(&holed, &Bridges::new(), |_| true, 1.0)
                .iter()
                .filter(|s| s.is_some())
                .count()
        })
    });
    g.finish();
}

criterion_group!(benches, moving);
criterion_main!(benches);
