//! One registration per built-in variant on fixed marina pairs (a synthetic pair when the
//! data is absent, said on the terminal), with the scans' surface estimates made beforehand as
//! the runner does; the surface estimates themselves; a registration in a fresh and in a
//! reused workspace; and the scaling of one HD_ICP registration with scan size.
//!
//!   ICP_DATA_DIR=/path/to/datasets cargo bench -p eval --bench variants

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use datasets::synthetic::{generate, ScannerConfig, Scenario};
use icp_core::variants::{builtin, builtins};
use icp_core::{Prepared, Registrar, Scan, SurfaceParams, Surfaces, Workspace};
use nalgebra::Isometry2;

fn pairs() -> (String, Vec<(Scan, Scan)>) {
    let picked = [10, 60, 100, 150];
    match datasets::marina::find_data_dir(None)
        .and_then(|d| datasets::marina::load(&d, &Default::default()))
    {
        Ok(ds) => (
            "marina".into(),
            picked
                .iter()
                .map(|&k| (ds.scans[k].clone(), ds.scans[k + 1].clone()))
                .collect(),
        ),
        Err(e) => {
            eprintln!("marina data absent ({e}); benchmarking synthetic marina-like pairs instead");
            let ds = generate(&Scenario::marina_like()).expect("synthetic data");
            (
                "synthetic".into(),
                picked
                    .iter()
                    .map(|&k| (ds.scans[k].clone(), ds.scans[k + 1].clone()))
                    .collect(),
            )
        }
    }
}

/// Each pair with both scans' surface estimates (the built-in variants share one parameter set).
fn prepared(pairs: &[(Scan, Scan)]) -> Vec<(Surfaces, Surfaces)> {
    let params = SurfaceParams::default();
    pairs
        .iter()
        .map(|(s, r)| {
            (
                Surfaces::estimate(s, &params),
                Surfaces::estimate(r, &params),
            )
        })
        .collect()
}

fn variants(c: &mut Criterion) {
    let (source, pairs) = pairs();
    let surfaces = prepared(&pairs);
    let mut group = c.benchmark_group(format!("register/{source}"));
    for spec in builtins() {
        let reg = spec.build().expect("valid");
        assert_eq!(reg.surface_params(), SurfaceParams::default());
        let mut workspace = Workspace::default();
        group.bench_function(&spec.name, |b| {
            b.iter(|| {
                for ((s, r), (ss, rs)) in pairs.iter().zip(&surfaces) {
                    reg.register_prepared(
                        &mut workspace,
                        Prepared::new(s, ss),
                        Prepared::new(r, rs),
                        Isometry2::identity(),
                    )
                    .expect("registers");
                }
            })
        });
    }
    group.finish();
}

/// The surface estimates of one scan: made once per scan and shared by every variant.
fn surfaces(c: &mut Criterion) {
    let (source, pairs) = pairs();
    let params = SurfaceParams::default();
    c.bench_function(&format!("surfaces/{source}"), |b| {
        b.iter(|| {
            for (s, _) in &pairs {
                Surfaces::estimate(s, &params);
            }
        })
    });
}

/// HD_ICP on each pair with a reused workspace (as the runner does) and with a fresh one.
fn workspace(c: &mut Criterion) {
    let (source, pairs) = pairs();
    let surfaces = prepared(&pairs);
    let reg = builtin("HD_ICP").expect("built in").build().expect("valid");
    let mut group = c.benchmark_group(format!("workspace/{source}"));
    let run = |workspace: &mut Workspace| {
        for ((s, r), (ss, rs)) in pairs.iter().zip(&surfaces) {
            reg.register_prepared(
                workspace,
                Prepared::new(s, ss),
                Prepared::new(r, rs),
                Isometry2::identity(),
            )
            .expect("registers");
        }
    };
    group.bench_function("reused", |b| {
        let mut workspace = Workspace::default();
        b.iter(|| run(&mut workspace))
    });
    group.bench_function("fresh", |b| b.iter(|| run(&mut Workspace::default())));
    group.finish();
}

fn scaling(c: &mut Criterion) {
    let mut group = c.benchmark_group("scaling/HD_ICP");
    group.sample_size(10);
    for beams in [100usize, 1_000, 10_000, 100_000] {
        let scenario = Scenario {
            n_scans: 2,
            scanner: ScannerConfig {
                sample_rate_hz: 5.0 * beams as f64,
                ..ScannerConfig::default()
            },
            ..Scenario::paper()
        };
        let ds = generate(&scenario).expect("synthetic pair");
        let reg = builtin("HD_ICP").expect("built in").build().expect("valid");
        let n = ds.scans[0].len();
        group.bench_with_input(BenchmarkId::from_parameter(n), &ds, |b, ds| {
            b.iter(|| {
                reg.register(&ds.scans[0], &ds.scans[1], Isometry2::identity())
                    .expect("registers")
            })
        });
    }
    group.finish();
}

criterion_group!(benches, variants, surfaces, workspace, scaling);
criterion_main!(benches);
