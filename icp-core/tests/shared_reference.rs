//! A workspace hands the reference index and the first matching of one registration to the
//! next that can use them (the other variants of a pair). Every registration must equal, bit
//! for bit, the same registration in a fresh workspace, whatever came before it.

use icp_core::variants::{builtin, builtin_names, VariantConfig};
use icp_core::{Registrar, Scan, Workspace};
use nalgebra::{Isometry2, Point2, Vector2};

/// A basin with quays, a pier and a hull, seen from `pose` (its points in the scanner frame).
fn scan_from(pose: Isometry2<f64>) -> Scan {
    let mut world = Vec::new();
    for i in 0..200 {
        let s = i as f64 * 0.2;
        world.push(Point2::new(-10.0 + s, 12.0 + 0.3 * (s * 0.4).sin()));
        world.push(Point2::new(-10.0 + s, -9.0));
        if i < 60 {
            world.push(Point2::new(4.0 + 0.1 * s, -9.0 + s));
            world.push(Point2::new(-10.0, -9.0 + 0.35 * s));
        }
    }
    let local: Vec<[f64; 2]> = world
        .iter()
        .map(|p| {
            let q = pose.inverse() * p;
            [q.x, q.y]
        })
        .collect();
    Scan::from_cartesian(&local).unwrap()
}

/// The built-in variants (the paper's four and the inverse-range example).
fn registrars() -> Vec<Box<dyn Registrar>> {
    builtin_names()
        .map(|n| {
            builtin(n, &VariantConfig::default())
                .unwrap()
                .build()
                .unwrap()
        })
        .collect()
}

#[test]
fn sharing_a_workspace_changes_no_registration() {
    let scans = [
        scan_from(Isometry2::identity()),
        scan_from(Isometry2::new(Vector2::new(1.1, 0.2), 0.03)),
        scan_from(Isometry2::new(Vector2::new(2.3, 0.3), 0.08)),
    ];
    let regs = registrars();
    let nudge = Isometry2::new(Vector2::new(0.5, 0.0), 0.01);
    let id = Isometry2::identity();
    // (variant, source, reference, init): every variant of a pair in turn, then a new
    // source on the same reference, a new reference, another start, and back.
    let mut steps = Vec::new();
    for v in 0..regs.len() {
        steps.push((v, 0, 1, id));
    }
    steps.extend([
        (0, 0, 1, nudge),
        (3, 2, 1, id),
        (1, 1, 2, id),
        (2, 0, 2, id),
        (3, 0, 1, id),
    ]);
    let mut shared = Workspace::default();
    for (k, &(v, a, b, init)) in steps.iter().enumerate() {
        // Before some steps, another variant prepares the pair, as the runner does.
        if k % 3 == 0 {
            let other = &regs[(v + 1) % regs.len()];
            other
                .prepare_in(&mut shared, &scans[a], &scans[b], init)
                .unwrap();
        }
        let got = regs[v]
            .register_in(&mut shared, &scans[a], &scans[b], init)
            .unwrap();
        let fresh = regs[v].register(&scans[a], &scans[b], init).unwrap();
        assert_eq!(got, fresh, "step {k}: {} {a}->{b}", regs[v].name());
    }
}

#[test]
fn a_prepared_pair_is_not_built_again() {
    let (a, b) = (
        scan_from(Isometry2::identity()),
        scan_from(Isometry2::new(Vector2::new(1.1, 0.2), 0.03)),
    );
    let regs = registrars();
    let id = Isometry2::identity();
    let count = |workspace: &mut Workspace, reg: &dyn Registrar| {
        allocation_counter::measure(|| {
            reg.register_in(workspace, &a, &b, id).unwrap();
        })
        .count_total
    };
    let mut workspace = Workspace::default();
    // Warm the buffers on another pair, then let K_ICP prepare this one.
    regs[0].register_in(&mut workspace, &b, &a, id).unwrap();
    regs[0].prepare_in(&mut workspace, &a, &b, id).unwrap();
    let after_prepare: Vec<u64> = regs.iter().map(|r| count(&mut workspace, &**r)).collect();
    regs[0].register_in(&mut workspace, &b, &a, id).unwrap();
    let unprepared = count(&mut workspace, &*regs[3]);
    // Only the overlap check allocates (its grid, 5 arrays, and bookkeeping, 5) once the pair
    // is prepared; unprepared, the grid index (5 arrays) is built as well.
    assert!(after_prepare.iter().all(|&c| c == 10), "{after_prepare:?}");
    assert_eq!(unprepared, 15);
}
