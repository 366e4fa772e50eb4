//! A scan as its scanner saw it: the range of each beam by bearing, for asking what the scanner
//! saw along a given ray.

use std::f64::consts::{PI, TAU};
use std::sync::OnceLock;

use nalgebra::Vector2;

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
    /// The unit vectors of the bins' edges, bearings −π + b·`bin_rad` for b in 0..=bins
    /// ([`edges`]; empty with fewer than [`MIN_WALK_BINS`] bins): a bearing lies within a bin
    /// when it turns past the bin's lower edge and short of its upper one, two cross products
    /// rather than a bearing.
    edges: Vec<Vector2<f64>>,
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
            edges: edges(bins, bin_rad),
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

    /// The windows of `half_width_rad` either side of a bearing (to within a bin, half a beam
    /// spacing): what a detector asks of a neighbour for every return of its scan.
    pub fn window(&self, half_width_rad: f64) -> Window<'_> {
        let bins = self.min_range_m.len();
        let reach = ((half_width_rad / self.bin_rad).round() as usize).min(bins / 2);
        let windows = self
            .windows
            .get_or_init(|| Windows::new(&self.min_range_m, reach));
        Window {
            image: self,
            reach,
            bins_per_rad: 1.0 / self.bin_rad,
            minima: (windows.reach == reach).then_some(windows.min_range_m.as_slice()),
            last: None,
        }
    }
}

/// Fewest bins for [`Window`]'s walk: two cross products place a bearing in one bin only when a
/// bin is narrower than a half turn (with four, a quarter turn at most).
const MIN_WALK_BINS: usize = 4;

/// Bins an edge's unit vector is turned on from the last one computed by `sin_cos` in
/// [`edges`].
const EDGES_PER_ANCHOR: usize = 64;

/// The unit vectors of the edges of `bins` bins of `bin_rad` from −π (`bins + 1` of them;
/// none below [`MIN_WALK_BINS`]): every [`EDGES_PER_ANCHOR`]-th from `sin_cos`, those between
/// turned on from it by one bin at a time (a product of two unit complex numbers rather than
/// a `sin_cos` per edge). Each lies within 10⁻¹³ rad of its bearing:
/// the anchor within 2·10⁻¹⁵ (the bearing's two roundings, `sin_cos`'s ulp), and each of at
/// most 63 turns adds the step's error (10⁻¹⁶) and the product's rounding (4·10⁻¹⁶).
fn edges(bins: usize, bin_rad: f64) -> Vec<Vector2<f64>> {
    if bins < MIN_WALK_BINS {
        return Vec::new();
    }
    let (step_sin, step_cos) = bin_rad.sin_cos();
    let mut edges = Vec::with_capacity(bins + 1);
    for b in 0..=bins {
        let edge = if b % EDGES_PER_ANCHOR == 0 {
            let (sin, cos) = (b as f64 * bin_rad - PI).sin_cos();
            Vector2::new(cos, sin)
        } else {
            let u: Vector2<f64> = edges[b - 1];
            Vector2::new(
                u.x * step_cos - u.y * step_sin,
                u.x * step_sin + u.y * step_cos,
            )
        };
        edges.push(edge);
    }
    edges
}

/// How far from a bin's edge (rad) the walk leaves the bin to `atan2`: 10⁴ times the edges'
/// error ([`edges`]) and the rounding of the cross products and of `atan2`'s own bin (a few
/// 10⁻¹⁵ rad), and 10⁻⁵ of the finest bin ([`MIN_BIN_RAD`]): a bearing falls this near an
/// edge of the rough harbour's bins (4·10⁻³ rad) about once in 2·10⁶.
const WALK_MARGIN_RAD: f64 = 1e-9;

/// Most bins the walk steps from its guess before it leaves the bearing to the polynomial
/// ([`Window::bin_towards`]): on the rough harbour (scans 10..190, 16 neighbours each), a guess
/// from the last bin and the bearing's turn in the scan's own frame is the bin itself for
/// 68 % of the returns, the next one for 25 %, and more than four away for 2 %.
const MAX_WALK_STEPS: usize = 4;

/// A bound on how far [`bearing_near_rad`] lies from `atan2`, rad: its polynomial's error
/// (2·10⁻⁸, Abramowitz & Stegun 4.4.49; `bearing_near_matches_atan2` measures it) with room
/// for the rounding of both.
const BEARING_NEAR_ERROR_RAD: f64 = 1e-7;

/// How near an edge of its bin (a share of a bin) a cheap bearing leaves the bin to `atan2`:
/// a bin is never narrower than [`MIN_BIN_RAD`]·(1 − 10⁻⁴), where
/// [`BEARING_NEAR_ERROR_RAD`] is 1.0·10⁻³ of it, and the rounding of both bins' arithmetic a
/// few ulp of a bin count below 63 000 (10⁻¹¹).
const EDGE_MARGIN_BINS: f64 = 2e-3;
const _: () = assert!(BEARING_NEAR_ERROR_RAD / (MIN_BIN_RAD * (1.0 - 1e-4)) < EDGE_MARGIN_BINS);

/// The bearing of `v`, rad, within [`BEARING_NEAR_ERROR_RAD`] of `v.y.atan2(v.x)`, from a
/// polynomial of the arctangent on [0, 1] (the octant) rather than `atan2` itself; `None` for
/// the origin or a point not finite.
fn bearing_near_rad(v: Vector2<f64>) -> Option<f64> {
    let (ax, ay) = (v.x.abs(), v.y.abs());
    let (small, large) = if ay > ax { (ax, ay) } else { (ay, ax) };
    if !(large > 0.0 && large.is_finite()) {
        return None;
    }
    let z = small / large;
    let z2 = z * z;
    // Abramowitz & Stegun 4.4.49: |error| ≤ 2·10⁻⁸ on [0, 1].
    const A: [f64; 8] = [
        0.002_866_225_7,
        -0.016_165_736_7,
        0.042_909_613_8,
        -0.075_289_640_0,
        0.106_562_639_3,
        -0.142_088_994_4,
        0.199_935_508_5,
        -0.333_331_452_8,
    ];
    let p = A.iter().fold(0.0, |acc, &a| acc * z2 + a);
    let octant = z + z * z2 * p;
    let first = if ay > ax {
        std::f64::consts::FRAC_PI_2 - octant
    } else {
        octant
    };
    let half = if v.x < 0.0 { PI - first } else { first };
    Some(if v.y < 0.0 { -half } else { half })
}

/// A [`RangeImage`] asked over windows of one width.
#[derive(Clone, Copy, Debug)]
pub struct Window<'a> {
    image: &'a RangeImage,
    /// Bins either side.
    reach: usize,
    /// Bins per radian, for the cheap bearings' bins (a product, not a division, per return).
    bins_per_rad: f64,
    /// Each bin's window's minimum, where the image holds them for this reach.
    minima: Option<&'a [f64]>,
    /// The bin of the last bearing asked, with the bearing it was asked along (`along_rad`
    /// of [`Window::nearest_range_m`]): where the walk to the next one starts.
    last: Option<(usize, f64)>,
}

impl Window<'_> {
    /// The shortest range among the returns within the window around the bearing of `towards`
    /// (a point in the scanner's frame; either side, across ±π), m; `None` when the scanner
    /// has no return there (no beam, or beams that met nothing within their range).
    ///
    /// `along_rad` is the bearing of the same point in the frame of the scan it belongs to (any
    /// bearing that turns with it): the bin is found by walking from the last one asked by as
    /// many bins as that bearing turned since. The answer is the same whatever `along_rad`
    /// says, only its cost is not: a detection asks a neighbour for its scan's returns in
    /// their order, so each walk is short.
    pub fn nearest_range_m(&mut self, towards: Vector2<f64>, along_rad: f64) -> Option<f64> {
        let all = &self.image.min_range_m;
        let bins = all.len();
        if bins == 0 {
            return None;
        }
        let centre = self
            .last
            .and_then(|(bin, from_rad)| self.walk(towards, bin, along_rad - from_rad))
            .or_else(|| self.bin_towards(towards));
        self.last = centre.map(|bin| (bin, along_rad));
        let centre = centre?;
        let nearest = match self.minima {
            Some(minima) => minima[centre],
            None => {
                // The window's bins, as at most two runs (it may cross ±π), without a division
                // per bin.
                let first = (centre + bins - self.reach) % bins;
                let last = first + 2 * self.reach;
                let (head, tail) = if last < bins {
                    (&all[first..=last], &[][..])
                } else {
                    (&all[first..], &all[..=last - bins])
                };
                head.iter()
                    .chain(tail)
                    .copied()
                    .fold(f64::INFINITY, f64::min)
            }
        };
        nearest.is_finite().then_some(nearest)
    }

    /// The bin of the bearing of `towards`, walked to from bin `from` (turned on by `turned_rad`
    /// first), where `towards` lies clear of its edges by [`WALK_MARGIN_RAD`]: `atan2`'s bin
    /// (a cross product of `towards` with an edge is |`towards`| times the sine of the angle
    /// between them, so both margins hold only inside the bin, and there `atan2` lies too).
    /// `None` near an edge, after [`MAX_WALK_STEPS`], or for an image too coarse to walk.
    fn walk(&self, towards: Vector2<f64>, from: usize, turned_rad: f64) -> Option<usize> {
        let edges = &self.image.edges;
        let bins = edges.len().checked_sub(1)?;
        // |x| + |y| is at least the norm: the margin, times it, is a sine of at least
        // WALK_MARGIN_RAD's share of a radian.
        let margin = WALK_MARGIN_RAD * (towards.x.abs() + towards.y.abs());
        let cross = |u: Vector2<f64>| u.x * towards.y - u.y * towards.x;
        // At most a revolution either way (a turn not finite walks from `from`: NaN casts to
        // 0), so one revolution added or taken brings the guess within the bins.
        let revolution = bins as f64;
        let ahead = (turned_rad * self.bins_per_rad).clamp(-revolution, revolution) as isize;
        let mut bin = match from as isize + ahead {
            b if b < 0 => b + bins as isize,
            b if b >= bins as isize => b - bins as isize,
            b => b,
        } as usize;
        for _ in 0..=MAX_WALK_STEPS {
            let (past_lower, past_upper) = (cross(edges[bin]), cross(edges[bin + 1]));
            if past_lower > margin && past_upper < -margin {
                return Some(bin);
            }
            bin = if past_lower < -margin {
                bin.checked_sub(1).unwrap_or(bins - 1)
            } else if past_upper > margin {
                if bin + 1 == bins {
                    0
                } else {
                    bin + 1
                }
            } else {
                // Within the margin of an edge (or not finite).
                return None;
            };
        }
        None
    }

    /// The bin of the bearing of `towards` (`None`: it has none that is finite): the bin of its
    /// `atan2` exactly, but found without one where a cheap bearing ([`bearing_near_rad`])
    /// lies clear of the bins' edges by more than its error (an `atan2` per return and
    /// neighbour was a third of `detect`'s cost).
    fn bin_towards(&self, towards: Vector2<f64>) -> Option<usize> {
        let bins = self.image.min_range_m.len();
        if let Some(near_rad) = bearing_near_rad(towards) {
            let at = (near_rad + PI) * self.bins_per_rad;
            // Within the margin of an edge, `atan2`'s bin may be the other one.
            let bin = at as usize;
            let past_m = at - bin as f64;
            if at >= 0.0 && past_m > EDGE_MARGIN_BINS && 1.0 - past_m > EDGE_MARGIN_BINS {
                return Some(bin.min(bins - 1));
            }
        }
        let bearing_rad = towards.y.atan2(towards.x);
        bearing_rad
            .is_finite()
            .then(|| bin_of(bearing_rad, self.image.bin_rad, bins))
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
        let towards = |deg: f64| Vector2::new(deg.to_radians().cos(), deg.to_radians().sin());
        assert!((image.spacing_rad() - 1f64.to_radians()).abs() < 1e-12);
        // Bearing 10° is index 190: range 191. Bins are half a degree: ±0.6° from 10.25° is
        // the bins from 9.5° to 11°, which hold 10° alone; ±1.6° reaches 9° (range 190).
        let r = image
            .window(0.6f64.to_radians())
            .nearest_range_m(towards(10.25), 0.0);
        assert_eq!(r, Some(191.0));
        let r = image
            .window(1.6f64.to_radians())
            .nearest_range_m(towards(10.25), 0.0);
        assert_eq!(r, Some(190.0));
        // Across ±π: −180° (range 1) and 179° (range 360) are both within 1.5° of 179.5°.
        let r = image
            .window(1.5f64.to_radians())
            .nearest_range_m(towards(179.5), 0.0);
        assert_eq!(r, Some(1.0));
        // A window with no beam.
        let sparse = Scan::from_polar(&[5.0, 6.0], &[0.0, 1.0]).unwrap();
        let image = RangeImage::new(&sparse);
        assert_eq!(
            image
                .window(0.1)
                .nearest_range_m(towards(0.5f64.to_degrees()), 0.0),
            None
        );
        assert_eq!(
            image
                .window(0.1)
                .nearest_range_m(towards(0.95f64.to_degrees()), 0.0),
            Some(6.0)
        );
    }

    /// Uniform draws from [0, 1) (xorshift64 from `seed`).
    fn uniform_from(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The image of a scan of beams every `spacing_deg` from −180°, each at 10 m.
    fn regular_image(spacing_deg: f64) -> RangeImage {
        let bearings: Vec<f64> = (0..(360.0 / spacing_deg) as usize)
            .map(|i| (i as f64 * spacing_deg - 180.0).to_radians())
            .collect();
        let ranges = vec![10.0; bearings.len()];
        RangeImage::new(&Scan::from_polar(&ranges, &bearings).unwrap())
    }

    /// The cheap bearing lies within its bound of `atan2`, and the bins found through it are
    /// `atan2`'s, at random and at the bins' very edges.
    #[test]
    fn bearing_near_matches_atan2() {
        let mut worst: f64 = 0.0;
        for i in 0..=1_000_000 {
            let z = i as f64 / 1e6;
            let v = Vector2::new(1.0, z);
            worst = worst.max((bearing_near_rad(v).unwrap() - z.atan()).abs());
        }
        assert!(worst < 3e-8, "{worst}");
        assert_eq!(bearing_near_rad(Vector2::zeros()), None);
        assert_eq!(bearing_near_rad(Vector2::new(f64::NAN, 1.0)), None);
        let mut uniform = uniform_from(0x2545_f491_4f6c_dd1d_u64);
        for spacing_deg in [0.5, 0.25, 0.37, 1.0] {
            let image = regular_image(spacing_deg);
            let bins = image.min_range_m.len();
            let window = image.window(0.0);
            let exact = |v: Vector2<f64>| bin_of(v.y.atan2(v.x), image.bin_rad, bins);
            for b in 0..=bins {
                let edge = b as f64 * image.bin_rad - PI;
                for offset in [-1e-6, -1e-9, -1e-12, 0.0, 1e-12, 1e-9, 1e-6] {
                    let r = 1.0 + 50.0 * uniform();
                    let v = Vector2::new((edge + offset).cos(), (edge + offset).sin()) * r;
                    assert_eq!(window.bin_towards(v), Some(exact(v)), "{v:?}");
                }
            }
            for _ in 0..200_000 {
                let v = Vector2::new(uniform() - 0.5, uniform() - 0.5) * 100.0;
                assert_eq!(window.bin_towards(v), Some(exact(v)), "{v:?}");
            }
        }
    }

    /// The walk finds `atan2`'s bin or none, from any bin and any turn, at random and at the
    /// bins' very edges; from a near guess it finds one nearly always; an image too coarse to
    /// walk, or a bearing not finite, has none.
    #[test]
    fn the_walk_finds_atan2s_bin_or_none() {
        let mut uniform = uniform_from(0x9e37_79b9_7f4a_7c15_u64);
        for spacing_deg in [0.5, 0.25, 0.37, 1.0, 40.0] {
            let image = regular_image(spacing_deg);
            let bins = image.min_range_m.len();
            assert_eq!(image.edges.len(), bins + 1);
            let window = image.window(0.0);
            let exact = |v: Vector2<f64>| bin_of(v.y.atan2(v.x), image.bin_rad, bins);
            let mut found = 0;
            for b in 0..=bins {
                let edge = b as f64 * image.bin_rad - PI;
                for offset in [-1e-3, -1e-8, -1e-9, -1e-10, 0.0, 1e-10, 1e-9, 1e-8, 1e-3] {
                    let v = Vector2::new((edge + offset).cos(), (edge + offset).sin())
                        * (1e-3 + 100.0 * uniform());
                    let from = (b + bins - 1) % bins;
                    let walked = window.walk(v, from, 0.0);
                    assert!(walked.is_none_or(|w| w == exact(v)), "{v:?}");
                    found += usize::from(walked.is_some());
                }
            }
            assert!(found >= 4 * bins, "{found} of {} found", 9 * (bins + 1));
            let mut near = 0;
            for _ in 0..100_000 {
                let v = Vector2::new(uniform() - 0.5, uniform() - 0.5) * 100.0;
                let from = (uniform() * bins as f64) as usize % bins;
                let turned = (uniform() - 0.5) * 20.0;
                let walked = window.walk(v, from, turned);
                assert!(
                    walked.is_none_or(|w| w == exact(v)),
                    "{v:?} {from} {turned}"
                );
                let guess = (exact(v) + bins - 1) % bins;
                near += usize::from(window.walk(v, guess, 0.0) == Some(exact(v)));
            }
            assert!(near > 99_900, "{near}");
            assert_eq!(window.walk(Vector2::new(f64::NAN, 1.0), 0, 0.0), None);
            assert_eq!(window.walk(Vector2::new(f64::INFINITY, 1.0), 0, 0.0), None);
            let v = Vector2::new(1.0, 1.0);
            for turned in [f64::NAN, f64::INFINITY, -1e300, 1e300] {
                assert!(window
                    .walk(v, bins - 1, turned)
                    .is_none_or(|w| w == exact(v)));
            }
        }
        let coarse = RangeImage::new(&Scan::from_polar(&[5.0, 6.0], &[-2.5, 2.5]).unwrap());
        assert!(coarse.edges.is_empty());
        assert_eq!(
            coarse.window(0.0).walk(Vector2::new(1.0, 0.0), 0, 0.0),
            None
        );
    }
}
