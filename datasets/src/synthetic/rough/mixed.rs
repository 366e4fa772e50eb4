//! Mixed pixels at depth edges: a footprint that straddles a near and a far surface returns a
//! range between them.
//!
//! The Sweep's beams are 0.48° apart and 8 mrad (0.46°) wide, so the beam next to a depth edge
//! lights both surfaces; its time-of-flight receiver then sees two overlapping echoes and
//! reports a range in between (Hebert & Krotkov 1992, "3D measurements from imaging laser
//! radars: how good are they?"; Tuley et al. 2005 on mixed pixels in single-return LIDARs).
//! Here, where two neighbouring beams meet surfaces more than `min_depth_step_m` apart, the
//! nearer-indexed beam becomes a mixed pixel with probability `probability`: its range is the
//! two true ranges mixed by a uniform fraction, and it has no true surface (no true normal).

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Mixed pixels at depth edges.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MixedPixels {
    /// Probability that a beam at a depth edge is mixed, in [0, 1].
    pub probability: f64,
    /// Smallest depth step that makes an edge, m.
    pub min_depth_step_m: f64,
}

impl MixedPixels {
    /// Half the edge beams, at steps over 0.3 m (a footprint at 20 m is 0.16 m wide).
    pub fn sweep() -> Self {
        Self {
            probability: 0.5,
            min_depth_step_m: 0.3,
        }
    }

    /// Turns edge beams into mixed pixels: `true_ranges_m[j]` is beam `j`'s noise-free range
    /// on a surface (NaN: none), `ranges_m` and `mixed` the reported ranges and whether each
    /// is mixed, updated in place.
    pub fn apply(
        &self,
        true_ranges_m: &[f64],
        ranges_m: &mut [f64],
        mixed: &mut [bool],
        rng: &mut ChaCha8Rng,
    ) {
        for j in 0..true_ranges_m.len().saturating_sub(1) {
            let (near, far) = (true_ranges_m[j], true_ranges_m[j + 1]);
            if !(near.is_finite() && far.is_finite())
                || (far - near).abs() <= self.min_depth_step_m
                || ranges_m[j].is_nan()
            {
                continue;
            }
            if rng.random_bool(self.probability) {
                ranges_m[j] = near + rng.random::<f64>() * (far - near);
                mixed[j] = true;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// Mixed pixels fall between the two surfaces, and only at depth edges.
    #[test]
    fn mixed_pixels_fall_between_the_two_surfaces() {
        let m = MixedPixels {
            probability: 1.0,
            ..MixedPixels::sweep()
        };
        // A hull at 8 m in front of a quay at 14 m, then open water (NaN).
        let truth = [14.0, 14.1, 8.0, 8.05, 8.1, 14.2, 14.3, f64::NAN];
        let mut ranges = truth;
        let mut mixed = [false; 8];
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        m.apply(&truth, &mut ranges, &mut mixed, &mut rng);
        assert_eq!(
            mixed,
            [false, true, false, false, true, false, false, false]
        );
        assert!(ranges[1] > 8.0 && ranges[1] < 14.1, "{}", ranges[1]);
        assert!(ranges[4] > 8.1 && ranges[4] < 14.2, "{}", ranges[4]);
        for j in [0, 2, 3, 5, 6] {
            assert_eq!(ranges[j], truth[j]);
        }
        // With probability one half, about half the edges over many revolutions.
        let half = MixedPixels::sweep();
        let mut count = 0;
        for _ in 0..2000 {
            let mut r = truth;
            let mut x = [false; 8];
            half.apply(&truth, &mut r, &mut x, &mut rng);
            count += x.iter().filter(|&&b| b).count();
        }
        // 4000 edge beams, binomial σ = 32.
        assert!((count as f64 - 2000.0).abs() < 130.0, "{count}");
    }
}
