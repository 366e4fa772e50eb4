//! Range noise that grows at grazing incidence: the beam's footprint spreads over depth.
//!
//! A beam of full divergence `δ` lights a spot `r δ` wide at range `r`. On a surface whose
//! normal makes the angle `i` with the beam, the spot covers depths over `r δ tan i`; on a
//! rough surface (concrete, fenders, hull plating) a time-of-flight receiver returns a range
//! anywhere in it (speckle and relief decide which part triggers), so the range gains a spread
//! of standard deviation `r δ tan i / √12` (uniform over the depth), added in quadrature to
//! the sensor's own. Zero mean: a leading-edge receiver's bias towards the near part is left
//! out. `tan i` is capped at [`MAX_TAN`] (85°). The Sweep's ranging module (Garmin LIDAR-Lite
//! v3) has `δ = 8 mrad` (its data sheet); at 20 m that adds 0.05 m at 45° and 0.13 m at 70°
//! incidence to the Sweep model's 0.085 m (`σ_r = 0.004258 r`).

use serde::{Deserialize, Serialize};

/// The largest `tan i` counted (85°).
pub const MAX_TAN: f64 = 11.43;

/// The footprint spread at grazing incidence.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GrazingNoise {
    /// Full beam divergence, radians.
    pub beam_divergence_rad: f64,
}

impl GrazingNoise {
    /// The Sweep's (LIDAR-Lite v3 data sheet): 8 mrad.
    pub fn sweep() -> Self {
        Self {
            beam_divergence_rad: 0.008,
        }
    }

    /// The standard deviation the footprint adds at range `range_m` and incidence whose
    /// cosine is `cos_incidence` (between the beam and the surface normal), m.
    pub fn sigma_m(&self, range_m: f64, cos_incidence: f64) -> f64 {
        let c = cos_incidence.abs().min(1.0);
        let tan = if c > 0.0 {
            ((1.0 - c * c).sqrt() / c).min(MAX_TAN)
        } else {
            MAX_TAN
        };
        range_m * self.beam_divergence_rad * tan / 12f64.sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spread_is_nothing_head_on_and_grows_with_incidence() {
        let g = GrazingNoise::sweep();
        assert_eq!(g.sigma_m(20.0, 1.0), 0.0);
        // 20 m, 60°: 20 · 0.008 · √3 / √12 = 0.08 m.
        assert!((g.sigma_m(20.0, 0.5) - 0.08).abs() < 1e-12);
        assert!(g.sigma_m(20.0, 0.2) > g.sigma_m(20.0, 0.5));
        // Capped at 85°.
        assert_eq!(g.sigma_m(20.0, 0.0), 20.0 * 0.008 * MAX_TAN / 12f64.sqrt());
    }
}
