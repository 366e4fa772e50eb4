//! A heavy-tailed share of range errors: multipath off the water and wet surfaces, and the
//! ranging module's own outliers at weak returns.
//!
//! A share `p` of the returns gets its range error from a Student t with `ν` degrees of freedom
//! scaled by `scale` times the return's σ, instead of the Gaussian. LIDAR range errors are
//! known to have heavier tails than a Gaussian (Pomerleau et al. 2012, "Noise
//! characterization of depth sensors for surface inspections", and the LIDAR-Lite v3 data
//! sheet's ±2.5 cm typical against occasional decimetre errors on dark or wet targets); the
//! defaults (`p = 0.03`, `ν = 3`, scale 3) make 3 % of the returns err by about 3σ and a few
//! by 10σ or more.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StudentT};
use serde::{Deserialize, Serialize};

/// The heavy-tailed share of range errors.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeavyTail {
    /// Share of the returns whose error is heavy-tailed, in [0, 1].
    pub share: f64,
    /// Degrees of freedom of the Student t (> 2, so that its variance is finite).
    pub dof: f64,
    /// Its scale, in units of the return's σ.
    pub scale_sigmas: f64,
}

impl HeavyTail {
    /// 3 % of the returns, t(3) at 3σ (see the module documentation).
    pub fn harbour() -> Self {
        Self {
            share: 0.03,
            dof: 3.0,
            scale_sigmas: 3.0,
        }
    }

    /// The range error in units of σ: `gaussian` (a standard normal draw) for most returns,
    /// a scaled t draw for the share.
    pub fn draw_sigmas(&self, gaussian: f64, rng: &mut ChaCha8Rng) -> f64 {
        if self.share > 0.0 && rng.random_bool(self.share) {
            let t = StudentT::new(self.dof).expect("validated: dof > 2");
            self.scale_sigmas * t.sample(rng)
        } else {
            gaussian
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::StandardNormal;

    /// The share beyond 6σ is the tail's: a Gaussian gives 2e-9 of it, the t(3) share
    /// `p · P(|t₃| > 2) = 0.03 · 0.1393 = 0.00418`.
    #[test]
    fn the_heavy_share_lies_beyond_six_sigma() {
        let tail = HeavyTail::harbour();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let n = 400_000;
        let beyond = (0..n)
            .filter(|_| {
                let g: f64 = rng.sample(StandardNormal);
                tail.draw_sigmas(g, &mut rng).abs() > 6.0
            })
            .count() as f64
            / n as f64;
        // Binomial σ of the fraction: √(0.00418 · 0.996 / 4e5) = 1.0e-4.
        assert!((beyond - 0.00418).abs() < 4e-4, "{beyond}");
        let none = HeavyTail { share: 0.0, ..tail };
        assert_eq!(none.draw_sigmas(0.25, &mut rng), 0.25);
    }
}
