//! The trajectories measured as evo measures them: the reference trajectory written beside the
//! estimated ones (`reference.tum`), and each variant's ATE and RPE against it as `evo_ape -a` /
//! `evo_rpe` compute them on those files (see [`crate::measure::trajectory_metrics`]).

use datasets::{Dataset, ScanPair};
use nalgebra::{Isometry2, UnitComplex, Vector2};
use serde::{Deserialize, Serialize};

use crate::measure::trajectory_metrics::{self as metrics, EvoStats};

/// The path length of the RPE segments, m (evo_rpe `--delta 5 --delta_unit m`): about four
/// steps of the paper's marina run (1.25 m per pair) and twenty of the synthetic `paper`
/// scenario (0.24 m), short enough that a 60-scan run has a few segments.
pub const RPE_SEGMENT_M: f64 = 5.0;

/// What `reference.tum` holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReferenceTum {
    /// The reference is a rigid pose of the scanner: positions and orientations.
    RigidPose,
    /// The reference gives positions only: the orientation is written as the identity, so
    /// only the translation ATE means anything (no rotation ATE, no RPE).
    PositionsOnly,
}

/// A variant's trajectory errors against `reference.tum`, with evo's statistics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EvoMetrics {
    /// Poses associated with the reference (same timestamps).
    pub poses: usize,
    /// ATE, translation part, after the SE(2) alignment, m (`evo_ape -a`).
    pub ate_trans_m: EvoStats,
    /// ATE rotation angle after the alignment, degrees (`evo_ape -a -r angle_deg`), where the
    /// reference has orientations.
    pub ate_rot_deg: Option<EvoStats>,
    /// RPE between consecutive poses, translation part, m (`evo_rpe`, delta 1 frame).
    pub rpe_trans_m: Option<EvoStats>,
    /// The same, rotation angle, degrees (`evo_rpe -r angle_deg`).
    pub rpe_rot_deg: Option<EvoStats>,
    /// Path length of the segments below, m (evo_rpe `--delta D --delta_unit m`, the path of
    /// the estimate as evo takes it by default).
    pub rpe_segment_m: f64,
    /// Segments of that path length found.
    pub rpe_segments: usize,
    /// RPE over those segments, translation part, m.
    pub rpe_segment_trans_m: Option<EvoStats>,
    /// The same, rotation angle, degrees.
    pub rpe_segment_rot_deg: Option<EvoStats>,
    /// A reflection of the plane fits the estimate's positions onto the reference's better
    /// than a rotation: evo's SE(3) alignment then mirrors the estimate and `evo_ape -a`
    /// differs from `ate_*` here (see [`metrics::reflection_fits_better`]); RPE is unaffected.
    #[serde(default)]
    pub mirror_fits_better: bool,
}

/// The reference pose at each pose of a chained trajectory: the poses of the scans the chain
/// passes through (the first pair's source, then each pair's reference scan), shifted by the
/// applied time offset `lag_scans`; `None` where the shifted scan is out of range. Positions
/// only (identity orientation) when the reference is not a rigid pose.
pub fn reference_trajectory(
    ds: &Dataset,
    pairs: &[ScanPair],
    lag_scans: i64,
) -> (Vec<Option<Isometry2<f64>>>, Option<ReferenceTum>) {
    let Some(reference) = &ds.reference else {
        return (Vec::new(), None);
    };
    let Some(first) = pairs.first() else {
        return (Vec::new(), None);
    };
    let rigid = ds.rigid_reference();
    let poses = std::iter::once(first.source)
        .chain(pairs.iter().map(|p| p.reference))
        .map(|k| {
            let r = reference.get(usize::try_from(k as i64 + lag_scans).ok()?)?;
            Some(r.scan_pose().unwrap_or_else(|| {
                Isometry2::from_parts(Vector2::new(r.x_m, r.y_m).into(), UnitComplex::identity())
            }))
        })
        .collect();
    let kind = if rigid {
        ReferenceTum::RigidPose
    } else {
        ReferenceTum::PositionsOnly
    };
    (poses, Some(kind))
}

/// The ATE and RPE of `estimate` against `reference` (pose i with pose i; poses without a
/// reference left out, as evo's association by timestamp leaves them out). `None` when the
/// alignment is not defined (fewer than two poses, or all at one point), and against a
/// reference of positions only: its positions and heading are not one rigid frame (marina's
/// GNSS positions advance along +x whatever the heading), so no chained trajectory aligns to
/// it and an ATE would measure that mismatch (about 21 m on marina), not the estimate.
pub fn evo_metrics(
    estimate: &[(f64, Isometry2<f64>)],
    reference: &[Option<Isometry2<f64>>],
    kind: ReferenceTum,
) -> Option<EvoMetrics> {
    if kind == ReferenceTum::PositionsOnly {
        return None;
    }
    let (est, refs): (Vec<Isometry2<f64>>, Vec<Isometry2<f64>>) = estimate
        .iter()
        .zip(reference)
        .filter_map(|((_, e), r)| Some((*e, (*r)?)))
        .unzip();
    let (_, ate) = metrics::ate(&est, &refs)?;
    let mirror_fits_better =
        metrics::reflection_fits_better(&metrics::positions(&est), &metrics::positions(&refs));
    let rpe = |pairs: &[(usize, usize)]| {
        let e = metrics::rpe(&est, &refs, pairs);
        (EvoStats::of(&e.trans_m), EvoStats::of(&e.rot_deg))
    };
    let (rpe_trans_m, rpe_rot_deg) = rpe(&metrics::pairs_by_frames(est.len(), 1));
    let segments = metrics::pairs_by_path(&est, RPE_SEGMENT_M);
    let (rpe_segment_trans_m, rpe_segment_rot_deg) = rpe(&segments);
    Some(EvoMetrics {
        poses: est.len(),
        ate_trans_m: EvoStats::of(&ate.trans_m)?,
        ate_rot_deg: EvoStats::of(&ate.rot_deg),
        rpe_trans_m,
        rpe_rot_deg,
        rpe_segment_m: RPE_SEGMENT_M,
        rpe_segments: segments.len(),
        rpe_segment_trans_m,
        rpe_segment_rot_deg,
        mirror_fits_better,
    })
}
