//! Nothing is allocated inside the ICP iteration loop: a registration allocates its buffers
//! once, so its allocation count does not grow with the number of iterations; and a workspace
//! passed from one registration to the next keeps them. Counted by `allocation-counter`'s
//! counting global allocator (this test binary only).

use icp_core::variants::builtins;
use icp_core::{Prepared, Registrar, Scan, Surfaces, Termination, Workspace};
use nalgebra::{Isometry2, Point2, Vector2};

/// Three walls with a bump, seen from the origin, and the same after a small motion.
fn pair() -> (Scan, Scan) {
    let pts: Vec<[f64; 2]> = (0..600)
        .map(|i| {
            let s = (i / 3) as f64 * 0.1;
            match i % 3 {
                0 => [12.0 + 0.3 * (s * 0.7).sin(), -9.0 + s],
                1 => [-6.0 + s, 10.0 + 0.2 * (s * 1.3).cos()],
                _ => [-6.0 + 0.5 * s, -9.0 - 0.2 * s],
            }
        })
        .collect();
    let t = Isometry2::new(Vector2::new(-0.4, 0.1), 0.02);
    let moved: Vec<[f64; 2]> = pts
        .iter()
        .map(|p| {
            let q = t * Point2::new(p[0], p[1]);
            [q.x, q.y]
        })
        .collect();
    (
        Scan::from_cartesian(&pts).unwrap(),
        Scan::from_cartesian(&moved).unwrap(),
    )
}

#[test]
fn allocations_do_not_grow_with_iterations() {
    let (source, reference) = pair();
    for spec in builtins() {
        let name = &spec.name;
        let run = |max_iterations: usize| {
            let mut spec = spec.clone();
            spec.termination = Termination {
                max_iterations,
                mean_residual_change_eps_m: 0.0,
                ..Default::default()
            };
            let reg = spec.build().unwrap();
            let mut iterations = 0;
            let params = reg.surface_params();
            let (s, r) = (
                Surfaces::estimate(&source, &params),
                Surfaces::estimate(&reference, &params),
            );
            let info = allocation_counter::measure(|| {
                iterations = reg
                    .register_prepared(
                        &mut Workspace::default(),
                        Prepared::new(&source, &s),
                        Prepared::new(&reference, &r),
                        Isometry2::identity(),
                    )
                    .unwrap()
                    .iterations;
            });
            (iterations, info.count_total)
        };
        let (one, many) = (run(1), run(40));
        assert_eq!(one.0, 1, "{name}");
        assert!(many.0 >= 10, "{name}: {} iterations", many.0);
        assert!(one.1 > 0, "{name}: the counter counts");
        assert_eq!(
            one.1, many.1,
            "{name}: allocations after 1 and {} iterations",
            many.0
        );
    }
}

#[test]
fn a_reused_workspace_keeps_the_buffers() {
    let (source, reference) = pair();
    // Another pair: the same scans swapped.
    let (other_source, other_reference) = (&reference, &source);
    for spec in builtins() {
        let name = &spec.name;
        let reg = spec.build().unwrap();
        let params = reg.surface_params();
        let (s, r) = (
            Surfaces::estimate(&source, &params),
            Surfaces::estimate(&reference, &params),
        );
        let count = |workspace: &mut Workspace, source: Prepared, reference: Prepared| {
            let mut out = None;
            let info = allocation_counter::measure(|| {
                out = Some(reg.register_prepared(
                    workspace,
                    source,
                    reference,
                    Isometry2::identity(),
                ));
            });
            (info.count_total, out.unwrap().unwrap())
        };
        let (a, b) = (Prepared::new(&source, &s), Prepared::new(&reference, &r));
        let (other_a, other_b) = (
            Prepared::new(other_source, &r),
            Prepared::new(other_reference, &s),
        );
        let (fresh, first) = count(&mut Workspace::default(), a, b);
        let (_, other_first) = count(&mut Workspace::default(), other_a, other_b);
        let mut workspace = Workspace::default();
        count(&mut workspace, a, b);
        let (warm_other, other_again) = count(&mut workspace, other_a, other_b);
        let (warm_same, again) = count(&mut workspace, a, b);
        // The same pair right after (as the next variant of a pair is): the index is kept.
        let (reused_index, once_more) = count(&mut workspace, a, b);
        assert_eq!(again, first, "{name}: a used workspace changes nothing");
        assert_eq!(once_more, first, "{name}: nor does a kept index");
        assert_eq!(other_again, other_first, "{name}: whatever pair it held");
        // What remains: the matcher's index (for the grid: a box, four arrays of its cells,
        // its copy of the points and its certificates), the matcher's spec that the workspace
        // compares with the index it kept, and the overlap check's two arrays; everything
        // else is the workspace's.
        assert_eq!(
            warm_same, warm_other,
            "{name}: a warm workspace allocates the same for any pair"
        );
        assert!(
            reused_index + 5 <= warm_same,
            "{name}: {reused_index} allocations with the index kept, {warm_same} without"
        );
        assert!(
            warm_same <= 10,
            "{name}: {warm_same} allocations with a warm workspace ({fresh} without)"
        );
        assert!(fresh > warm_same + 10, "{name}: {fresh} vs {warm_same}");
    }
}
