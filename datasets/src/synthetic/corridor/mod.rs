//! `synthetic:corridor`: an indoor robot lapping an office building's corridors with a SICK
//! LMS-class scanner, with exact ground truth, where the scene repeats (a row of identical
//! offices) and runs bare for tens of metres (corridor stretches whose walls pin nothing along
//! them). Built for issue 36's ambiguity work, where its parameters are chosen; the CARMEN
//! `aces` log stays the check.
//!
//! - The floor ([`building`]): a 72 m × 24 m loop of 2 m corridors, 0.9 m doors into offices
//!   and a laboratory, niches, and a 60 m bare stretch.
//! - The robot ([`route`]): laps of the loop on the corridor's centre line, 0.3–0.5 m between
//!   scans on straight stretches, turning on the spot at corners and at the laboratory door
//!   by 18–20° between scans; a scan every [`Corridor::dt_s`] (1 s: an indoor robot's
//!   0.3–0.5 m/s). The reference is the scanner's own pose (the scanner offset is the
//!   identity), [`crate::ReferenceKind::GroundTruth`].
//! - The people ([`people`]): three walking the corridors at 1.0–1.4 m/s; their returns are
//!   labelled moving ([`icp_core::Scan::moving`]), and only theirs.
//! - The scanner: the CARMEN logs' SICK LMS 2xx, 180 beams 1° apart over 180° in front (the
//!   centres of 1° cells from −90° to 90°), its noise model [`SICK_LMS2XX`] (σ_r = 1 cm at
//!   every range, σ_α = 0.5°), the same 50 m maximum range as the CARMEN loader's
//!   ([`crate::carmen::CarmenOptions`]: a wall beyond it returns nothing), cast by the
//!   harbour's [`Scanner`] with its dropouts and spurious returns. Each return keeps the true
//!   normal of the wall it came from ([`icp_core::Scan::true_normals`]).
//!
//! Frames: the world is x east, y north; the scanner's `+x` is the robot's heading and
//! bearings grow counter-clockwise; the reference heading is the yaw, counter-clockwise.

use icp_core::BearingSense;
use nalgebra::Isometry2;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::carmen::SICK_LMS2XX;
use crate::dataset::{Dataset, ReferencePose};
use crate::DatasetError;

use super::{
    check_ranges, ground_truth_dataset, run_checks, Scanner, ScannerConfig, NOISE_SEED_MIX,
};

pub mod building;
pub mod people;
pub mod route;

use people::{Walker, PEOPLE_STREAM};

/// The ChaCha8 stream of the route's step draws.
const ROUTE_STREAM: u64 = 37;

/// The corridor scenario's run: how many scans, how often, the scanner and the seed.
#[derive(Clone, Debug, PartialEq)]
pub struct Corridor {
    /// Number of scans: 440 by default, as many as the CARMEN `aces` log has (about one lap).
    pub n_scans: usize,
    /// Time between scans, s: 1 s, so the steps are an indoor robot's 0.3–0.5 m/s. (`aces`
    /// has a scan every 3 s and 0.74 m on average.)
    pub dt_s: f64,
    /// The scanner: [`SICK_LMS2XX`]'s noise, 50 m range, 360 samples a turn of the mirror
    /// (1° apart, the LMS 2xx's 75 Hz at 1° resolution), 1 % dropouts (dark or glossy
    /// surfaces, glass), 0.2 % spurious returns, no motion distortion (a 13 ms sweep).
    pub scanner: ScannerConfig,
    /// Field of view, degrees: the beams in front of the 360 a turn samples.
    pub field_of_view_deg: f64,
    /// Seed of the route's steps, the people's starting places and the noise.
    pub seed: u64,
}

impl Default for Corridor {
    fn default() -> Self {
        Self {
            n_scans: 440,
            dt_s: 1.0,
            scanner: ScannerConfig {
                sensor: SICK_LMS2XX,
                noise: true,
                max_range_m: 50.0,
                rotation_hz: 75.0,
                sample_rate_hz: 27_000.0,
                dropout_prob: 0.01,
                gross_error_fraction: 0.002,
                motion_distortion: false,
            },
            field_of_view_deg: 180.0,
            seed: 2036,
        }
    }
}

impl Corridor {
    /// The scenario's name.
    pub const NAME: &'static str = "corridor";

    /// Why the time between scans and the speed are not options of the scenario.
    pub const PLANNED_PER_SCAN: &'static str = "the corridor robot's motion is planned per \
         scan (0.3–0.5 m, up to 20° between scans): another spacing would change its speed, \
         not its steps";

    /// The beams' bearings, radians: the centres of the turn's sample cells within the field
    /// of view, symmetric about the heading.
    pub fn bearings_rad(&self) -> Vec<f64> {
        let step_deg = 360.0 / self.scanner.beams_per_rev() as f64;
        let count = (self.field_of_view_deg / step_deg).round() as usize;
        let first_deg = -0.5 * step_deg * count as f64 + 0.5 * step_deg;
        (0..count)
            .map(|j| (first_deg + step_deg * j as f64).to_radians())
            .collect()
    }

    fn validate(&self) -> Result<(), DatasetError> {
        check_ranges(run_checks(self.n_scans, self.dt_s))?;
        check_ranges([(
            "field_of_view_deg",
            self.field_of_view_deg,
            self.field_of_view_deg.is_finite()
                && self.field_of_view_deg > 0.0
                && self.field_of_view_deg <= 360.0,
        )])?;
        self.scanner.validate()
    }
}

/// Generates the corridor scenario's dataset.
pub fn generate_corridor(corridor: &Corridor) -> Result<Dataset, DatasetError> {
    corridor.validate()?;
    let stream = |k: u64| {
        let mut rng = ChaCha8Rng::seed_from_u64(corridor.seed);
        rng.set_stream(k);
        rng
    };
    let poses: Vec<Isometry2<f64>> = route::poses(corridor.n_scans, &mut stream(ROUTE_STREAM));
    let walkers = Walker::office(&mut stream(PEOPLE_STREAM));
    let mut event_rng = ChaCha8Rng::seed_from_u64(corridor.seed);
    let mut noise_rng = ChaCha8Rng::seed_from_u64(corridor.seed ^ NOISE_SEED_MIX);
    let walls = building::walls();
    let bearings = corridor.bearings_rad();
    let mut scans = Vec::with_capacity(corridor.n_scans);
    let mut reference = Vec::with_capacity(corridor.n_scans);
    for (k, pose) in poses.iter().enumerate() {
        let t_k = k as f64 * corridor.dt_s;
        let mut world = walls.clone();
        world.extend(walkers.iter().flat_map(|w| w.outline(t_k)));
        let scanner = Scanner::with_moving_from(&corridor.scanner, &world, walls.len());
        let rev = scanner.scan_fan(pose, &bearings, &mut noise_rng, &mut event_rng);
        scans.push(rev.scan(k, t_k)?);
        let yaw = pose.rotation.angle();
        reference.push(ReferencePose {
            x_m: pose.translation.x,
            y_m: pose.translation.y,
            heading_rad: yaw,
            scan_yaw_rad: Some(yaw),
        });
    }
    let description = format!(
        "synthetic office corridors, scenario \"corridor\": {} scans every {} s, {} beams over \
         {}° (SICK LMS 2xx model, {} m range), {} walking people, seed {}",
        corridor.n_scans,
        corridor.dt_s,
        bearings.len(),
        corridor.field_of_view_deg,
        corridor.scanner.max_range_m,
        walkers.len(),
        corridor.seed,
    );
    Ok(ground_truth_dataset(
        (Corridor::NAME, description),
        (scans, reference),
        BearingSense::CounterClockwise,
        corridor.dt_s,
        // Every beam is cast from the scan's pose.
        0.0,
        corridor.scanner.sensor,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fan_is_180_beams_1_degree_apart_about_the_heading() {
        let b = Corridor::default().bearings_rad();
        assert_eq!(b.len(), 180);
        assert!((b[0].to_degrees() + 89.5).abs() < 1e-12, "{}", b[0]);
        assert!((b[179].to_degrees() - 89.5).abs() < 1e-12);
        for w in b.windows(2) {
            assert!(((w[1] - w[0]).to_degrees() - 1.0).abs() < 1e-12);
        }
    }
}
