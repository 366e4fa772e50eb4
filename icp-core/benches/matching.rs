//! Matcher build and query cost at several sizes: grid vs k-d tree vs Delaunay vs brute force.
//!
//!   cargo bench -p icp-core --bench matching

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use icp_core::matching::{BruteForce, Delaunay, Grid, KdTree, Matcher};
use nalgebra::{Point2, Vector2};

/// A LIDAR-like point set: walls at ranges 5–35 m around the sensor, `n` returns.
fn scan(n: usize, phase: f64) -> Vec<Point2<f64>> {
    (0..n)
        .map(|i| {
            let a = phase + i as f64 * std::f64::consts::TAU / n as f64;
            let r = 20.0 + 15.0 * (3.0 * a).sin() * (0.5 * a).cos();
            Point2::new(r * a.cos(), r * a.sin())
        })
        .collect()
}

fn bench_matcher(c: &mut Criterion, name: &str, matcher: &dyn Matcher, sizes: &[usize]) {
    let mut group = c.benchmark_group(format!("matching/{name}"));
    for &n in sizes {
        let reference = scan(n, 0.0);
        // Queries: the next scan, moved by a small step, as ICP asks them.
        let queries: Vec<Point2<f64>> = scan(n, 0.3 / n as f64)
            .iter()
            .map(|p| p + Vector2::new(0.05, -0.02))
            .collect();
        group.bench_with_input(BenchmarkId::new("build", n), &reference, |b, r| {
            b.iter(|| matcher.build(r).unwrap())
        });
        let mut out = Vec::with_capacity(n);
        group.bench_with_input(BenchmarkId::new("query_all_cold", n), &queries, |b, q| {
            b.iter_batched_ref(
                || matcher.build(&reference).unwrap(),
                |index| index.match_all(q, &mut out),
                criterion::BatchSize::SmallInput,
            )
        });
        let mut index = matcher.build(&reference).unwrap();
        // Two calls per iteration on queries 1 mm apart, as late ICP iterations ask them.
        let nudged: Vec<Point2<f64>> = queries
            .iter()
            .map(|p| p + Vector2::new(1e-3, 0.0))
            .collect();
        index.match_all(&queries, &mut out);
        group.bench_with_input(
            BenchmarkId::new("query_all_warm_x2", n),
            &queries,
            |b, q| {
                b.iter(|| {
                    index.match_all(&nudged, &mut out);
                    index.match_all(q, &mut out);
                })
            },
        );
    }
    group.finish();
}

fn matching(c: &mut Criterion) {
    let sizes = [200, 700, 2_000, 10_000, 100_000];
    bench_matcher(c, "grid", &Grid, &sizes);
    bench_matcher(c, "kdtree", &KdTree, &sizes);
    bench_matcher(c, "delaunay", &Delaunay, &sizes[..4]);
    bench_matcher(c, "brute", &BruteForce, &sizes[..3]);
}

criterion_group!(benches, matching);
criterion_main!(benches);
