//! One registration per variant on fixed marina pairs (a synthetic pair when the data is
//! absent, said on the terminal), the four paper variants of each pair with and without a
//! shared workspace, and the scaling of one HD_ICP registration with scan size.
//!
//!   ICP_DATA_DIR=/path/to/datasets cargo bench -p eval --bench variants

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use datasets::synthetic::{generate, ScannerConfig, Scenario};
use icp_core::variants::{builtin, builtin_names, VariantConfig};
use icp_core::{Scan, Workspace};
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

fn variants(c: &mut Criterion) {
    let (source, pairs) = pairs();
    let mut group = c.benchmark_group(format!("register/{source}"));
    for name in builtin_names() {
        let reg = builtin(name, &VariantConfig::default())
            .expect("built in")
            .build()
            .expect("valid");
        group.bench_function(name, |b| {
            b.iter(|| {
                for (s, r) in &pairs {
                    reg.register(s, r, Isometry2::identity())
                        .expect("registers");
                }
            })
        });
    }
    group.finish();
}

/// The paper's four variants on each pair, as the runner does (one workspace: the first
/// variant's preparation is shared) and one registration at a time (a fresh workspace each).
fn shared_pair(c: &mut Criterion) {
    let (source, pairs) = pairs();
    let regs: Vec<_> = ["K_ICP", "H_ICP", "HM_ICP", "HD_ICP"]
        .iter()
        .map(|n| {
            builtin(n, &VariantConfig::default())
                .expect("built in")
                .build()
                .expect("valid")
        })
        .collect();
    let mut group = c.benchmark_group(format!("four_variants/{source}"));
    group.bench_function("one_workspace", |b| {
        let mut workspace = Workspace::default();
        b.iter(|| {
            for (s, r) in &pairs {
                for reg in &regs {
                    reg.register_in(&mut workspace, s, r, Isometry2::identity())
                        .expect("registers");
                }
            }
        })
    });
    group.bench_function("fresh_workspaces", |b| {
        b.iter(|| {
            for (s, r) in &pairs {
                for reg in &regs {
                    reg.register(s, r, Isometry2::identity())
                        .expect("registers");
                }
            }
        })
    });
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
        let reg = builtin("HD_ICP", &VariantConfig::default())
            .expect("built in")
            .build()
            .expect("valid");
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

criterion_group!(benches, variants, shared_pair, scaling);
criterion_main!(benches);
