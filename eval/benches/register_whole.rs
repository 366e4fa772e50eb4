//! One whole registration as `icp_bench.register` makes it (both scans' surface estimates,
//! a fresh workspace, then the chain) on four synthetic marina-like pairs: the Rust side of
//! the Python package's overhead figure (`icp-py/benches/overhead.py` times the same pairs
//! through Python; reports/performance.md).
//!
//!   cargo bench -p eval --bench register_whole

use criterion::{criterion_group, criterion_main, Criterion};
use datasets::synthetic::{generate, Scenario};
use icp_core::variants::builtin;
use icp_core::Registrar;
use nalgebra::Isometry2;

/// The pairs `icp-py/benches/overhead.py` registers: scans k → k+1 of the marina-like scenario.
const PICKED: [usize; 4] = [10, 60, 100, 150];

fn register_whole(c: &mut Criterion) {
    let ds = generate(&Scenario::marina_like()).expect("synthetic data");
    let mut group = c.benchmark_group("register_whole/synthetic");
    for name in ["HD_ICP", "IR_ICP", "HD_GICP"] {
        let mut spec = builtin(name).expect("built in");
        spec.sensor = ds.sensor;
        let reg = spec.build().expect("valid");
        group.bench_function(name, |b| {
            b.iter(|| {
                for &k in &PICKED {
                    let r = reg.register(&ds.scans[k], &ds.scans[k + 1], Isometry2::identity());
                    std::hint::black_box(r.expect("registers"));
                }
            })
        });
    }
    group.finish();
}

criterion_group!(benches, register_whole);
criterion_main!(benches);
