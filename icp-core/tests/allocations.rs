//! Nothing is allocated inside the ICP iteration loop: a registration allocates its buffers
//! once, so its allocation count does not grow with the number of iterations; and a workspace
//! passed from one registration to the next keeps them. Counted by `allocation-counter`'s
//! counting global allocator (this test binary only).

use icp_core::variants::{builtin, builtin_names, VariantConfig};
use icp_core::{Scan, Termination, Workspace};
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
    for name in builtin_names() {
        let run = |max_iterations: usize| {
            let mut spec = builtin(name, &VariantConfig::default()).unwrap();
            spec.termination = Termination {
                max_iterations,
                mean_dist_change_eps_m: 1e-300,
            };
            let reg = spec.build().unwrap();
            let mut iterations = 0;
            let info = allocation_counter::measure(|| {
                iterations = reg
                    .register(&source, &reference, Isometry2::identity())
                    .unwrap()
                    .iterations;
            });
            (iterations, info.count_total)
        };
        let (one, many) = (run(1), run(40));
        assert_eq!(one.0, 1, "{name}");
        assert!(many.0 >= 10, "{name}: {} iterations", many.0);
        assert!(one.1 > 0, "{name}: the counter counts");
        // Bytes may differ: the overlap check after the loop sizes a grid to the final pose.
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
    // Another pair: the same scans swapped, so the reference index must be rebuilt.
    let (other_source, other_reference) = (&reference, &source);
    for name in builtin_names() {
        let reg = builtin(name, &VariantConfig::default())
            .unwrap()
            .build()
            .unwrap();
        let count = |workspace: &mut Workspace, source: &Scan, reference: &Scan| {
            let mut out = None;
            let info = allocation_counter::measure(|| {
                out = Some(reg.register_in(workspace, source, reference, Isometry2::identity()));
            });
            (info.count_total, out.unwrap().unwrap())
        };
        let (fresh, first) = count(&mut Workspace::default(), &source, &reference);
        let (_, other_first) = count(&mut Workspace::default(), other_source, other_reference);
        let mut workspace = Workspace::default();
        count(&mut workspace, &source, &reference);
        // Warm, another pair: the buffers are reused, the grid index is rebuilt.
        let (warm_other, other_again) = count(&mut workspace, other_source, other_reference);
        // Warm, the same pair again: the grid index and the first matching are reused too.
        count(&mut workspace, &source, &reference);
        let (warm_same, again) = count(&mut workspace, &source, &reference);
        assert_eq!(again, first, "{name}: a used workspace changes nothing");
        assert_eq!(other_again, other_first, "{name}: nor does a stale index");
        // What remains: the overlap check's grid (5 arrays) and its bookkeeping (5), plus the
        // grid index (5) when the reference changed; everything else is the workspace's.
        assert_eq!(
            (warm_other, warm_same),
            (15, 10),
            "{name}: allocations with a warm workspace ({fresh} without)"
        );
        assert!(fresh > warm_other + 10, "{name}: {fresh} vs {warm_other}");
    }
}
