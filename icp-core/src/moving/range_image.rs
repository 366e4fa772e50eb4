//! A scan as its scanner saw it: the range of each beam by bearing, for asking what the scanner
//! saw along a given ray.

use std::f64::consts::{PI, TAU};
use std::sync::OnceLock;

use crate::Scan;

/// The shortest range of one scan's returns per bearing bin (half the scan's beam spacing
/// wide), with the scan's beam spacing: a window of bearings is a run of bins.
#[derive(Clone, Debug, Default)]
pub struct RangeImage {
    /// Per bin from −π, the shortest range of its returns, m (infinite: none).
    min_range_m: Vec<f64>,
    /// Bin width, rad.
    bin_rad: f64,
    /// The median gap between neighbouring bearings, rad (0 with fewer than two returns).
    spacing_rad: f64,
    /// The minima of the windows of the first reach asked, made on that ask: a detector asks
    /// every return of each of its scan's neighbours with one window (its width follows from
    /// the neighbour's spacing and the sensor), and an image is the neighbour of 16 scans
    /// (k−8..k+8) in each round, so a window's minimum is read, not folded, from the second
    /// ask on (`detect`'s cost was mostly these folds: 3–17 bins per return and neighbour).
    windows: OnceLock<Windows>,
}

/// Per bin, the shortest range within `reach` bins of it (either side, across ±π).
#[derive(Clone, Debug)]
struct Windows {
    reach: usize,
    min_range_m: Vec<f64>,
}

impl Windows {
    /// The windows of `reach` (at most half the bins) over `min_range_m`.
    fn new(min_range_m: &[f64], reach: usize) -> Self {
        let bins = min_range_m.len();
        // Bin c's window is bins c−reach..=c+reach, which start at `extended[c]`.
        let extended: Vec<f64> = min_range_m[bins - reach..]
            .iter()
            .chain(min_range_m)
            .chain(&min_range_m[..reach])
            .copied()
            .collect();
        let min_range_m = extended
            .windows(2 * reach + 1)
            .map(|w| w.iter().copied().fold(f64::INFINITY, f64::min))
            .collect();
        Self { reach, min_range_m }
    }
}

/// Bins per beam spacing.
const BINS_PER_BEAM: f64 = 2.0;
/// The finest bin, rad, whatever the spacing (a scan with coincident bearings).
const MIN_BIN_RAD: f64 = 1e-4;

impl RangeImage {
    /// The range image of `scan` (bearings from its points, so whatever the dataset's sense).
    pub fn new(scan: &Scan) -> Self {
        let bearings: Vec<f64> = scan
            .returns()
            .iter()
            .map(|r| r.point.y.atan2(r.point.x))
            .collect();
        let mut sorted = bearings.clone();
        sorted.sort_by(f64::total_cmp);
        let mut gaps: Vec<f64> = sorted
            .windows(2)
            .map(|w| w[1] - w[0])
            .filter(|&g| g > 0.0)
            .collect();
        gaps.sort_by(f64::total_cmp);
        let spacing_rad = gaps.get(gaps.len() / 2).copied().unwrap_or(0.0);
        let bins = ((TAU / (spacing_rad / BINS_PER_BEAM).max(MIN_BIN_RAD)).ceil() as usize).max(1);
        let bin_rad = TAU / bins as f64;
        let mut min_range_m = vec![f64::INFINITY; bins];
        for (r, &bearing_rad) in scan.returns().iter().zip(&bearings) {
            let b = bin_of(bearing_rad, bin_rad, bins);
            min_range_m[b] = min_range_m[b].min(r.range_m);
        }
        Self {
            min_range_m,
            bin_rad,
            spacing_rad,
            windows: OnceLock::new(),
        }
    }

    /// The median gap between neighbouring bearings, rad.
    pub fn spacing_rad(&self) -> f64 {
        self.spacing_rad
    }

    /// The shortest range among the returns within `half_width_rad` of `bearing_rad` (either
    /// side, across ±π; to within a bin, half a beam spacing), m; `None` when the scanner has
    /// no return there (no beam, or beams that met nothing within their range).
    pub fn nearest_range_m(&self, bearing_rad: f64, half_width_rad: f64) -> Option<f64> {
        let bins = self.min_range_m.len();
        if bins == 0 || !bearing_rad.is_finite() {
            return None;
        }
        let centre = bin_of(bearing_rad, self.bin_rad, bins);
        let reach = ((half_width_rad / self.bin_rad).round() as usize).min(bins / 2);
        let windows = self
            .windows
            .get_or_init(|| Windows::new(&self.min_range_m, reach));
        if windows.reach == reach {
            let nearest = windows.min_range_m[centre];
            return nearest.is_finite().then_some(nearest);
        }
        // The window's bins, as at most two runs (it may cross ±π), without a division per bin.
        let first = (centre + bins - reach) % bins;
        let last = first + 2 * reach;
        let (head, tail) = if last < bins {
            (&self.min_range_m[first..=last], &[][..])
        } else {
            (
                &self.min_range_m[first..],
                &self.min_range_m[..=last - bins],
            )
        };
        let nearest = head
            .iter()
            .chain(tail)
            .copied()
            .fold(f64::INFINITY, f64::min);
        nearest.is_finite().then_some(nearest)
    }
}

/// The bin of `bearing_rad` among `bins` of `bin_rad` from −π.
fn bin_of(bearing_rad: f64, bin_rad: f64, bins: usize) -> usize {
    let from = bearing_rad + PI;
    // An atan2 lies within [0, 2π] from −π: `rem_euclid` (a division) only outside [0, 2π),
    // where it changes the value.
    let from = if (0.0..TAU).contains(&from) {
        from
    } else {
        from.rem_euclid(TAU)
    };
    ((from / bin_rad) as usize).min(bins - 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_nearest_range_in_a_window_across_the_back() {
        let bearings: Vec<f64> = (0..360).map(|i| (i as f64 - 180.0).to_radians()).collect();
        let ranges: Vec<f64> = (0..360).map(|i| 1.0 + i as f64).collect();
        let image = RangeImage::new(&Scan::from_polar(&ranges, &bearings).unwrap());
        assert!((image.spacing_rad() - 1f64.to_radians()).abs() < 1e-12);
        // Bearing 10° is index 190: range 191. Bins are half a degree: ±0.6° from 10.25° is
        // the bins from 9.5° to 11°, which hold 10° alone; ±1.6° reaches 9° (range 190).
        let r = image.nearest_range_m(10.25f64.to_radians(), 0.6f64.to_radians());
        assert_eq!(r, Some(191.0));
        let r = image.nearest_range_m(10.25f64.to_radians(), 1.6f64.to_radians());
        assert_eq!(r, Some(190.0));
        // Across ±π: −180° (range 1) and 179° (range 360) are both within 1.5° of 179.5°.
        let r = image.nearest_range_m(179.5f64.to_radians(), 1.5f64.to_radians());
        assert_eq!(r, Some(1.0));
        // A window with no beam.
        let sparse = Scan::from_polar(&[5.0, 6.0], &[0.0, 1.0]).unwrap();
        let image = RangeImage::new(&sparse);
        assert_eq!(image.nearest_range_m(0.5, 0.1), None);
        assert_eq!(image.nearest_range_m(0.95, 0.1), Some(6.0));
    }
}
