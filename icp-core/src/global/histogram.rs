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
            // rem_euclid may round up to TAU itself: the bin index wraps.
            let b = lower as usize % bins;
            weights[b] += 1.0 - frac;
            weights[(b + 1) % bins] += frac;
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
        let correlation: Vec<f64> = (0..bins)
            .map(|k| {
                (0..bins)
                    .map(|b| source.weights[b] * reference.weights[(b + k) % bins])
                    .sum()
            })
            .collect();
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
}
