//! Wave-driven motion of a small hull: surge, sway and yaw added to the track, roll and pitch
//! tilting the scan plane.
//!
//! Each degree of freedom is a sum of sinusoids (a few lines of a wave spectrum) with phases
//! drawn from the scenario's seed. The defaults ([`SeaState::sheltered_basin`]) are a
//! Douglas sea state 2 ("smooth", significant wave height 0.1–0.5 m) inside a yacht basin,
//! where a short wind chop of 2–4 s period dominates (WMO Code 3700; Faltinsen 1990, "Sea
//! loads on ships and offshore structures", ch. 2): a 1.6 m hull (the paper's USV) follows it
//! in heave, roll and pitch by a few degrees and yaws slowly by a few degrees at 0.1–0.3 Hz
//! (the figure; a small hull's yaw is driven by the wave groups, not the single waves).

use nalgebra::{Isometry2, Vector2};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// One sinusoid of a motion: `amplitude · sin(2π t / period_s + phase)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wave {
    /// Amplitude, in the unit of the motion it belongs to (m or degrees).
    pub amplitude: f64,
    /// Period, seconds.
    pub period_s: f64,
}

/// The wave-driven motion of the hull about its track.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeaState {
    /// Along the bow, m.
    pub surge_m: Vec<Wave>,
    /// To port, m.
    pub sway_m: Vec<Wave>,
    /// Heading about the track's, degrees (counter-clockwise positive).
    pub yaw_deg: Vec<Wave>,
    /// Roll, degrees (positive: starboard down, so port beams point up).
    pub roll_deg: Vec<Wave>,
    /// Pitch, degrees (positive: bow up, so forward beams point up).
    pub pitch_deg: Vec<Wave>,
}

impl SeaState {
    /// A sheltered yacht basin in sea state 2 (see the module documentation): surge 0.10 m
    /// and sway 0.08 m at 3.5–4 s; yaw 2.0° at 6.7 s (0.15 Hz) and 1.0° at 3.7 s (0.27 Hz);
    /// roll 2.5° at 2.5 s and 1.0° at 3.3 s; pitch 1.2° at 2.2 s.
    pub fn sheltered_basin() -> Self {
        let w = |amplitude, period_s| Wave {
            amplitude,
            period_s,
        };
        Self {
            surge_m: vec![w(0.10, 3.5)],
            sway_m: vec![w(0.08, 4.0)],
            yaw_deg: vec![w(2.0, 6.7), w(1.0, 3.7)],
            roll_deg: vec![w(2.5, 2.5), w(1.0, 3.3)],
            pitch_deg: vec![w(1.2, 2.2)],
        }
    }

    /// Every wave, for validation.
    pub(super) fn waves(&self) -> impl Iterator<Item = &Wave> {
        [
            &self.surge_m,
            &self.sway_m,
            &self.yaw_deg,
            &self.roll_deg,
            &self.pitch_deg,
        ]
        .into_iter()
        .flatten()
    }

    /// The motion with its phases drawn from `rng` (one per wave, in the order of the fields).
    pub fn with_phases(&self, rng: &mut ChaCha8Rng) -> SeaMotion {
        let mut draw = |waves: &[Wave]| -> Vec<(Wave, f64)> {
            waves
                .iter()
                .map(|w| (*w, rng.random_range(0.0..std::f64::consts::TAU)))
                .collect()
        };
        SeaMotion {
            surge_m: draw(&self.surge_m),
            sway_m: draw(&self.sway_m),
            yaw_deg: draw(&self.yaw_deg),
            roll_deg: draw(&self.roll_deg),
            pitch_deg: draw(&self.pitch_deg),
        }
    }
}

/// A [`SeaState`] with its phases: the motion as a function of time.
#[derive(Clone, Debug, PartialEq)]
pub struct SeaMotion {
    surge_m: Vec<(Wave, f64)>,
    sway_m: Vec<(Wave, f64)>,
    yaw_deg: Vec<(Wave, f64)>,
    roll_deg: Vec<(Wave, f64)>,
    pitch_deg: Vec<(Wave, f64)>,
}

fn sum(waves: &[(Wave, f64)], t_s: f64) -> f64 {
    waves
        .iter()
        .map(|(w, phase)| w.amplitude * (std::f64::consts::TAU * t_s / w.period_s + phase).sin())
        .sum()
}

impl SeaMotion {
    /// The hull's offset from its track pose at `t_s` (in the track pose's frame): surge,
    /// sway and yaw. The scanner's pose is `track ∘ offset`.
    pub fn offset(&self, t_s: f64) -> Isometry2<f64> {
        Isometry2::new(
            Vector2::new(sum(&self.surge_m, t_s), sum(&self.sway_m, t_s)),
            sum(&self.yaw_deg, t_s).to_radians(),
        )
    }

    /// Roll and pitch at `t_s`, radians.
    pub fn attitude_rad(&self, t_s: f64) -> (f64, f64) {
        (
            sum(&self.roll_deg, t_s).to_radians(),
            sum(&self.pitch_deg, t_s).to_radians(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// The waves move the hull: each motion stays within the sum of its amplitudes and
    /// reaches most of it over a minute, and yaw oscillates at its periods.
    #[test]
    fn the_waves_move_the_hull_within_their_amplitudes() {
        let sea = SeaState::sheltered_basin();
        let motion = sea.with_phases(&mut ChaCha8Rng::seed_from_u64(9));
        let (mut surge, mut yaw, mut roll, mut pitch) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for i in 0..6000 {
            let t = i as f64 * 0.01;
            let o = motion.offset(t);
            surge = surge.max(o.translation.x.abs());
            yaw = yaw.max(o.rotation.angle().to_degrees().abs());
            let (r, p) = motion.attitude_rad(t);
            roll = roll.max(r.to_degrees().abs());
            pitch = pitch.max(p.to_degrees().abs());
        }
        assert!(surge > 0.09 && surge <= 0.10 + 1e-12, "{surge}");
        assert!(yaw > 2.0 && yaw <= 3.0 + 1e-12, "{yaw}");
        assert!(roll > 2.5 && roll <= 3.5 + 1e-12, "{roll}");
        assert!(pitch > 1.1 && pitch <= 1.2 + 1e-12, "{pitch}");
        // Another seed, other phases.
        let other = sea.with_phases(&mut ChaCha8Rng::seed_from_u64(10));
        assert_ne!(other.offset(1.0), motion.offset(1.0));
    }
}
