//! Quality checks of a registration at its solution, made after the loop: how well the final
//! pairs constrain the motion (conditioning) and how much the two scans overlap. They flag a
//! registration whose number cannot be trusted; they never change it.

use nalgebra::{Matrix3, Point2, SymmetricEigen, Vector2, Vector3};

use crate::matching::Correspondence;
use crate::surface::SurfacePoint;

/// A final pair closer than this counts as overlap, metres: a few times the pair distances of
/// a converged marina registration (0.11 m on average, from noise and 0.48° beam spacing).
pub const OVERLAP_GATE_M: f64 = 0.5;

/// Source points per run of the overlap check's search.
const OVERLAP_RUN: usize = 16;

/// Below this overlap fraction a registration is flagged as having no overlap: the scans do
/// not see the same surfaces, and the motion that aligns their point clouds means nothing.
/// On the marina data and the synthetic harbour, H/HM/HD_ICP registrations score 0.88 and
/// more; K_ICP's local minima go down to 0.15 and stay above the threshold on purpose: they
/// are wrong registrations of overlapping scans and belong in K_ICP's error statistics.
pub const MIN_OVERLAP: f64 = 0.1;

/// The conditioning of the registration at its solution: the eigenvalues of the Gauss-Newton
/// Hessian `H = Σ J Jᵀ / N` of eq. 14 (unit weights: the geometry of the final pairs)
/// linearised along the reference surface normals (point-to-line), with
/// `J = [n_x, n_y, (p − m) × n / L]`: `n` the reference point's surface normal (see
/// [`crate::surface`]), `p` the moved source point, `m` their centroid and `L` their RMS
/// distance from it, so all three directions are in metres. A corridor or a single wall
/// leaves one direction unconstrained (a near-zero eigenvalue); point-to-point ICP still
/// returns a number there, which is why it is flagged rather than trusted.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Conditioning {
    /// Eigenvalues of H, ascending (dimensionless: mean squared normal components).
    pub eigenvalues: [f64; 3],
    /// Smallest over largest eigenvalue, in [0, 1].
    pub ratio: f64,
}

/// Below this conditioning ratio a registration is flagged as degenerate. A scene with walls
/// in every direction scores ~0.1–0.5; a straight corridor scores below 0.001.
pub const DEGENERATE_RATIO: f64 = 0.01;

impl Conditioning {
    /// True when one motion direction is barely constrained.
    pub fn degenerate(&self) -> bool {
        self.ratio.is_nan() || self.ratio < DEGENERATE_RATIO
    }
}

/// The conditioning of the final pairs (see [`Conditioning`]), from the reference surface
/// normals of the pairs' reference points (pairs without one are left out).
pub fn conditioning(
    moved: &[Point2<f64>],
    dst_surfaces: &[Option<SurfacePoint>],
    pairs: &[Correspondence],
) -> Option<Conditioning> {
    if pairs.is_empty() {
        return None;
    }
    let n = pairs.len() as f64;
    let m = pairs
        .iter()
        .map(|c| moved[c.src].coords)
        .sum::<Vector2<f64>>()
        / n;
    let l = (pairs
        .iter()
        .map(|c| (moved[c.src].coords - m).norm_squared())
        .sum::<f64>()
        / n)
        .sqrt();
    if l.is_nan() || l <= 0.0 {
        return None;
    }
    let mut h = Matrix3::zeros();
    let mut used = 0;
    for c in pairs {
        let Some(nrm) = dst_surfaces[c.dst].map(|s| s.normal) else {
            continue;
        };
        let r = moved[c.src].coords - m;
        let j = Vector3::new(nrm.x, nrm.y, (r.x * nrm.y - r.y * nrm.x) / l);
        h += j * j.transpose();
        used += 1;
    }
    if used < 3 {
        return None;
    }
    let e = SymmetricEigen::new(h / used as f64).eigenvalues;
    let mut ev = [e[0], e[1], e[2]];
    ev.sort_by(f64::total_cmp);
    let eigenvalues = [ev[0].max(0.0), ev[1], ev[2]];
    let ratio = if eigenvalues[2] > 0.0 {
        eigenvalues[0] / eigenvalues[2]
    } else {
        0.0
    };
    Some(Conditioning { eigenvalues, ratio })
}

/// The smaller of two fractions: of the final pairs closer than [`OVERLAP_GATE_M`] (source
/// points near the reference) and of the reference points that near the moved source points.
/// Both are needed: a small scan can settle inside a larger one with most of its own points
/// near surfaces.
pub fn overlap(moved: &[Point2<f64>], dst: &[Point2<f64>], pairs: &[Correspondence]) -> f64 {
    let gate_sq = OVERLAP_GATE_M * OVERLAP_GATE_M;
    if pairs.is_empty() || dst.is_empty() {
        return 0.0;
    }
    let forward = pairs.iter().filter(|p| p.dist_sq <= gate_sq).count() as f64 / pairs.len() as f64;
    // A reference point is near without a search when it is a close pair's, or close to the
    // source point paired with a scan neighbour of it; the others (a few tens on overlapping
    // scans) are searched for among the source points.
    // Per reference point: the source point of its last pair, and whether a pair is close.
    let mut partner: Vec<(Option<usize>, bool)> = vec![(None, false); dst.len()];
    for p in pairs {
        let (source, near) = &mut partner[p.dst];
        *source = Some(p.src);
        *near |= p.dist_sq <= gate_sq;
    }
    let close = |i: usize, q: &Point2<f64>| (moved[i] - q).norm_squared() <= gate_sq;
    // The exhaustive search visits only the runs of consecutive source points whose bounding
    // box, widened by the gate, holds the reference point: the same answer, far fewer points.
    let runs: Vec<[f64; 4]> = moved
        .chunks(OVERLAP_RUN)
        .map(|run| {
            run.iter().fold(
                [
                    f64::INFINITY,
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                    f64::NEG_INFINITY,
                ],
                |[x0, y0, x1, y1], m| [x0.min(m.x), y0.min(m.y), x1.max(m.x), y1.max(m.y)],
            )
        })
        .collect();
    // Widened by far more than the rounding of the coordinates, so that no point the distance
    // test would accept is skipped. (A NaN point is left out of its run's box, and fails the
    // distance test anyway.)
    let reach = OVERLAP_GATE_M * (1.0 + 1e-6);
    let near_any = |q: &Point2<f64>| {
        runs.iter().enumerate().any(|(k, &[x0, y0, x1, y1])| {
            let outside =
                q.x < x0 - reach || q.x > x1 + reach || q.y < y0 - reach || q.y > y1 + reach;
            !outside && {
                let start = k * OVERLAP_RUN;
                (start..(start + OVERLAP_RUN).min(moved.len())).any(|i| close(i, q))
            }
        })
    };
    let backward_near = dst
        .iter()
        .enumerate()
        .filter(|&(j, q)| {
            partner[j].1
                || [j.wrapping_sub(1), j + 1]
                    .iter()
                    .filter_map(|&k| partner.get(k).and_then(|p| p.0))
                    .any(|i| close(i, q))
                || near_any(q)
        })
        .count();
    let backward = backward_near as f64 / dst.len() as f64;
    forward.min(backward)
}
