//! Rotation hypotheses from orientation histograms (Weiss & von Puttkamer 1995, "A map based
//! on laserscans without geometric interpretation", IAS-4): the directions of the surface
//! normals of each scan are histogrammed over the full circle, and the peaks of the circular
//! cross-correlation of the two histograms are the rotations that bring the source's surfaces
//! parallel to the reference's.
//!
//! Each usable normal (see [`crate::surface`]) votes for the two bins around its direction,
//! in proportion to its closeness to their centres (linear binning), so that a direction on
//! a bin border does not split the peak at random. Normals face the sensor, so a wall seen
//! from the same side keeps its direction: the full circle tells a rotation from its
//! opposite.

use std::f64::consts::TAU;

use crate::Surfaces;

/// The histogram of the normal directions of one scan, bin `b` centred at `b · 2π / bins`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct OrientationHistogram {
    weights: Vec<f64>,
}

impl OrientationHistogram {
    /// The histogram of `surfaces`' usable normals in `bins` bins (at least 1).
    pub fn new(surfaces: &Surfaces, bins: usize) -> Self {
        let mut weights = vec![0.0; bins];
        let per_rad = bins as f64 / TAU;
        for s in surfaces.points().iter().flatten() {
            let angle = s.normal.y.atan2(s.normal.x);
            if !angle.is_finite() {
                continue;
            }
            let x = angle.rem_euclid(TAU) * per_rad;
            let lower = x.floor();
            let frac = x - lower;
            // rem_euclid may round up to TAU itself: the bin index wraps (x is in [0, bins],
            // so once at most, without a division).
            let wrap = |b: usize| if b >= bins { b - bins } else { b };
            let b = wrap(lower as usize);
            weights[b] += 1.0 - frac;
            weights[wrap(b + 1)] += frac;
        }
        Self { weights }
    }

    /// Bins of the histogram.
    pub fn bins(&self) -> usize {
        self.weights.len()
    }

    /// The rotations (radians, in `[0, 2π)`) at the `count` highest local maxima of the
    /// circular cross-correlation `c(k) = Σ_b source[b] · reference[b + k]`, highest first
    /// (ties: the smaller rotation first); fewer when the correlation has fewer positive
    /// maxima (none for a scan without usable normals). Both histograms have the same bins.
    pub fn rotation_peaks(source: &Self, reference: &Self, count: usize) -> Vec<f64> {
        let bins = source.bins();
        let correlation = source.correlation(reference);
        let at = |k: usize| correlation[k % bins];
        // A maximum rises from its left neighbour and does not fall to its right one: one per
        // plateau, none on a flat correlation.
        let mut peaks: Vec<usize> = (0..bins)
            .filter(|&k| {
                let c = correlation[k];
                c > 0.0 && c > at(k + bins - 1) && c >= at(k + 1)
            })
            .collect();
        peaks.sort_by(|&a, &b| correlation[b].total_cmp(&correlation[a]));
        peaks.truncate(count);
        peaks
            .into_iter()
            .map(|k| k as f64 * TAU / bins as f64)
            .collect()
    }

    /// The circular cross-correlation `c(k) = Σ_b self[b] · reference[b + k]`, summed in
    /// increasing `b`. Empty bins of either histogram add +0.0 terms, which change no sum
    /// that has a positive term: only the pairs of occupied bins are summed, each `c(k)`'s
    /// in increasing `b` as the definition's (a sum of +0.0 terms alone may come out as
    /// −0.0, which compares as 0).
    fn correlation(&self, reference: &Self) -> Vec<f64> {
        let bins = self.bins();
        let occupied = |h: &Self| -> Vec<(usize, f64)> {
            h.weights
                .iter()
                .enumerate()
                .filter(|&(_, &w)| w != 0.0)
                .map(|(b, &w)| (b, w))
                .collect()
        };
        let (mine, theirs) = (occupied(self), occupied(reference));
        // The empty sum, as the definition's `Iterator::sum` starts it.
        let mut correlation = vec![std::iter::empty::<f64>().sum::<f64>(); bins];
        for &(b, w) in &mine {
            for &(r, v) in &theirs {
                let k = if r >= b { r - b } else { r + bins - b };
                correlation[k] += w * v;
            }
        }
        correlation
    }
}

#[cfg(test)]
mod tests {
    use super::OrientationHistogram;
    use proptest::prelude::*;

    proptest! {
        /// Summing the occupied bins only gives the definition's sums bit for bit (equal as
        /// numbers where every term is 0).
        #[test]
        fn correlation_is_the_definitions(
            pairs in prop::collection::vec((0.0..3.0f64, 0.0..3.0f64, 0u8..3), 4..60),
        ) {
            // About a third of the source's bins empty, as most are in a scan's histogram.
            let source = OrientationHistogram {
                weights: pairs.iter().map(|&(s, _, z)| if z == 0 { 0.0 } else { s }).collect(),
            };
            let reference = OrientationHistogram {
                weights: pairs.iter().map(|&(_, r, z)| if z == 1 { 0.0 } else { r }).collect(),
            };
            let bins = source.bins();
            let fast = source.correlation(&reference);
            for (k, &c) in fast.iter().enumerate() {
                let naive: f64 = (0..bins)
                    .map(|b| source.weights[b] * reference.weights[(b + k) % bins])
                    .sum();
                if naive > 0.0 {
                    prop_assert_eq!(c.to_bits(), naive.to_bits());
                } else {
                    prop_assert_eq!(c, naive);
                }
            }
        }
    }
}
