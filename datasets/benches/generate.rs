//! Generating the synthetic harbour: the ray casting of each revolution (its sector index
//! against testing every near segment), on 100 scans of the paper scenario, and 100 of the rough
//! harbour.
//!
//!   cargo bench -p datasets --bench generate

use criterion::{criterion_group, criterion_main, Criterion};
use datasets::synthetic::{generate, Scenario};

fn generation(c: &mut Criterion) {
    let mut group = c.benchmark_group("generate");
    group.sample_size(20);
    for distortion in [false, true] {
        let mut scenario = Scenario {
            n_scans: 100,
            ..Scenario::paper()
        };
        scenario.scanner.motion_distortion = distortion;
        let name = if distortion {
            "paper_100_scans_distorted"
        } else {
            "paper_100_scans"
        };
        group.bench_function(name, |b| {
            b.iter(|| generate(&scenario).expect("valid scenario"))
        });
    }
    // The rough harbour: waves, tilt, boats and the other sources, with motion distortion.
    let rough = Scenario {
        n_scans: 100,
        ..Scenario::rough()
    };
    group.bench_function("rough_100_scans", |b| {
        b.iter(|| generate(&rough).expect("valid scenario"))
    });
    group.finish();
}

criterion_group!(benches, generation);
criterion_main!(benches);
