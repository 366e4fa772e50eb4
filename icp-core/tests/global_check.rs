//! The check of a result against the global search (`GlobalMatcher::best_above`) against the
//! full search: on random scenes, motions, results and margins, asked one after the other on
//! one preparation, it answers with the full search's best pose exactly when that pose clears
//! the bar, and otherwise with a bound the full search's best does not exceed and that does
//! not clear; so any decision taken from the best pose is the same.

mod common;

use common::{seen_from, Owned};
use icp_core::global::{
    score_at, Above, GlobalMatcher, GlobalParams, GlobalWorkspace, RotationMode,
};
use nalgebra::{Isometry2, Point2, Vector2};
use proptest::prelude::*;

/// Walls through `corners` (a closed polyline), sampled every `step_m` from `phase_m`.
fn walls(corners: &[(f64, f64)], step_m: f64, phase_m: f64) -> Vec<Point2<f64>> {
    let mut points = Vec::new();
    for (k, &a) in corners.iter().enumerate() {
        let b = corners[(k + 1) % corners.len()];
        let (a, b) = (Point2::new(a.0, a.1), Point2::new(b.0, b.1));
        let length = (b - a).norm();
        let mut s = phase_m;
        while s < length {
            points.push(a + (b - a) * (s / length));
            s += step_m;
        }
    }
    points
}

/// The suspect rule of the evaluation's check: a clearly better pose far away.
fn decision(
    best: &Isometry2<f64>,
    best_score: f64,
    result: &Isometry2<f64>,
    result_score: f64,
    margin: f64,
) -> bool {
    let apart_m = (best.translation.vector - result.translation.vector).norm();
    let apart_deg = (result.inverse() * best)
        .rotation
        .angle()
        .to_degrees()
        .abs();
    best_score - result_score > margin && (apart_m > 0.3 || apart_deg > 3.0)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn the_check_answers_as_the_full_search(
        corners in prop::collection::vec((-6.0..6.0f64, -6.0..6.0f64), 3..7),
        motion in (-0.8..0.8f64, -0.8..0.8f64, -40.0..40.0f64),
        results in prop::collection::vec((-1.0..1.0f64, -1.0..1.0f64, -60.0..60.0f64, 0u8..3), 1..6),
        margin in 0.0..0.3f64,
        full_rotations in any::<bool>(),
        window_m in 0.3..1.2f64,
        resolution_m in 0.08..0.2f64,
    ) {
        let truth = Isometry2::new(Vector2::new(motion.0, motion.1), motion.2.to_radians());
        let scene = walls(&corners, 0.05, 0.0);
        prop_assume!(scene.len() >= 10);
        let reference = Owned::new(seen_from(&scene, &Isometry2::identity()));
        let source = Owned::new(seen_from(&walls(&corners, 0.05, 0.02), &truth));
        let params = GlobalParams {
            rotation: if full_rotations { RotationMode::Full } else { RotationMode::Histogram },
            max_rotation_deg: 60.0,
            angular_step_deg: Some(1.5),
            window_m,
            resolution_m,
            sigma_m: resolution_m,
            ..GlobalParams::default()
        };
        let matcher = GlobalMatcher::new(reference.prepared(), &params).unwrap();
        let full = matcher
            .search(&mut GlobalWorkspace::default(), source.prepared(), Isometry2::identity())
            .unwrap();
        let mut workspace = GlobalWorkspace::default();
        let mut prepared = matcher
            .prepare(&mut workspace, source.prepared(), Isometry2::identity())
            .unwrap();
        for &(x, y, deg, kind) in &results {
            // Near the truth, anywhere, or at the search's best pose itself.
            let result = match kind {
                0 => truth * Isometry2::new(Vector2::new(x, y) * 0.05, (deg * 0.02).to_radians()),
                1 => Isometry2::new(Vector2::new(x, y), deg.to_radians()),
                _ => full.t_ref_src,
            };
            let result_score = score_at(matcher.grid(), &source.scan, &result);
            let clears = |s: f64| s - result_score > margin;
            let today = decision(&full.t_ref_src, full.score, &result, result_score, margin);
            match matcher.best_above(&mut prepared, clears) {
                Above::Best { t_ref_src, score } => {
                    prop_assert_eq!(t_ref_src, full.t_ref_src);
                    prop_assert_eq!(score, full.score);
                    prop_assert!(clears(score));
                    prop_assert_eq!(decision(&t_ref_src, score, &result, result_score, margin), today);
                }
                Above::AtMost { score } => {
                    prop_assert!(!clears(full.score), "{} clears", full.score);
                    prop_assert!(!clears(score));
                    prop_assert!(full.score <= score, "{} > bound {}", full.score, score);
                    prop_assert!(!today);
                }
            }
        }
    }
}
