//! The vessel's track, integrated from the scenario's heading and speed.

use nalgebra::{Isometry2, Vector2};

use super::Scenario;

/// The vessel's track: scanner poses sampled finely in time.
pub(super) struct Track {
    pub(super) step_s: f64,
    pub(super) poses: Vec<Isometry2<f64>>,
}

impl Track {
    const SUBSTEPS: usize = 50;

    pub(super) fn new(scenario: &Scenario, duration_s: f64) -> Self {
        let step_s = scenario.dt_s / Self::SUBSTEPS as f64;
        let n = (duration_s / step_s).ceil() as usize + 2;
        let yaw = |t: f64| (90.0 - scenario.heading_deg(t)).to_radians();
        let mut p = Vector2::zeros();
        let mut poses = Vec::with_capacity(n);
        for i in 0..n {
            let t = i as f64 * step_s;
            poses.push(Isometry2::new(p, yaw(t)));
            // Midpoint rule; the truth is whatever is integrated here, so it is exact by
            // construction whatever the integration error.
            let tm = t + 0.5 * step_s;
            p += Vector2::new(yaw(tm).cos(), yaw(tm).sin()) * scenario.speed_mps(tm) * step_s;
        }
        Self { step_s, poses }
    }

    /// Pose at time `t_s`: exact at the samples, interpolated between them.
    pub(super) fn pose_at(&self, t_s: f64) -> Isometry2<f64> {
        let x = t_s / self.step_s;
        let i = (x.floor() as usize).min(self.poses.len() - 2);
        let f = x - i as f64;
        if f == 0.0 {
            return self.poses[i];
        }
        self.poses[i].lerp_slerp(&self.poses[i + 1], f)
    }
}
