//! Reference preparation: the local surface behind each return (a normal and a covariance),
//! estimated once per scan from the principal components of its nearest neighbours, and
//! shared, as plain data, by every registration that uses the scan and by the quality checks.
//!
//! For each return, the up to `max_neighbours` nearest points of the same scan within
//! `radius_m` (the return itself included) give a mean `m` (kept: the fitted line passes
//! through it) and a scatter
//! `S = Σ (p − m)(p − m)ᵀ / k` with eigenvalues `λ_t ≥ λ_n` and eigenvectors `t` (along the
//! surface) and `n` (the normal). The estimate is usable when there are at least
//! `min_neighbours` of them and the neighbourhood is line-like, `λ_n ≤ max_thickness_ratio ·
//! λ_t` (a corner or clutter has no single normal). Its covariance is the scatter regularised as
//! in generalised ICP (Segal et al. 2009, "Generalized-ICP", RSS; there the eigenvalues are
//! replaced by `(ε, 1)`): `C = λ_t t tᵀ + max(λ_n, ε λ_t) n nᵀ`, `ε = min_variance_ratio`, in m²
//! so that a sensor covariance (eq. 8) can be added to it. Returns without a usable estimate are
//! counted ([`Surfaces::unusable`]) and never used by a metric that needs a normal.

use nalgebra::{Matrix2, Point2, Vector2};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::cells::Cells;
use crate::registry::ParamError;
use crate::Scan;

/// How the surface behind each return is estimated.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct SurfaceParams {
    /// Most points in an estimate, the return itself included.
    pub max_neighbours: usize,
    /// Fewest points within `radius_m` for a usable estimate, the return itself included.
    pub min_neighbours: usize,
    /// Points farther than this from the return are not its neighbours, metres.
    pub radius_m: f64,
    /// Largest ratio of the across-surface to the along-surface variance of a usable estimate:
    /// above it the neighbourhood is not line-like (a corner, clutter), dimensionless.
    pub max_thickness_ratio: f64,
    /// Floor of the across-surface variance as a fraction of the along-surface one in the
    /// covariance (generalised ICP's ε), dimensionless.
    pub min_variance_ratio: f64,
}

impl Default for SurfaceParams {
    fn default() -> Self {
        Self {
            max_neighbours: 10,
            min_neighbours: 5,
            radius_m: 1.0,
            max_thickness_ratio: 0.1,
            min_variance_ratio: 1e-3,
        }
    }
}

impl SurfaceParams {
    /// `Err` naming the first parameter outside its domain.
    pub fn validate(&self) -> Result<(), ParamError> {
        if self.min_neighbours < 3 {
            return Err(ParamError::new(
                "min_neighbours",
                self.min_neighbours,
                "at least 3 points are needed for a line fit with a residual",
            ));
        }
        if self.max_neighbours < self.min_neighbours {
            return Err(ParamError::new(
                "max_neighbours",
                self.max_neighbours,
                "must be at least min_neighbours",
            ));
        }
        ParamError::check_positive("radius_m", self.radius_m)?;
        if !(self.max_thickness_ratio > 0.0 && self.max_thickness_ratio <= 1.0) {
            return Err(ParamError::new(
                "max_thickness_ratio",
                self.max_thickness_ratio,
                "must be in (0, 1]",
            ));
        }
        if !(self.min_variance_ratio > 0.0 && self.min_variance_ratio <= 1.0) {
            return Err(ParamError::new(
                "min_variance_ratio",
                self.min_variance_ratio,
                "must be in (0, 1]",
            ));
        }
        Ok(())
    }
}

/// The local surface at one return, in its scan's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// Unit normal, pointing towards the sensor (`n · p ≤ 0`).
    pub normal: Vector2<f64>,
    /// The regularised neighbourhood covariance, m² (see the module doc).
    pub covariance: Matrix2<f64>,
    /// The neighbourhood's mean, in the scan frame: a point of the fitted line, less noisy
    /// along the normal than the return itself.
    pub mean: Point2<f64>,
}

/// The surface estimates of every return of one scan, made with one set of parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct Surfaces {
    params: SurfaceParams,
    points: Vec<Option<SurfacePoint>>,
    unusable: usize,
}

impl Surfaces {
    /// Estimates the surface at every return of `scan` (parameters assumed valid: see
    /// [`SurfaceParams::validate`]).
    pub fn estimate(scan: &Scan, params: &SurfaceParams) -> Self {
        let points: Vec<Point2<f64>> = scan.returns().iter().map(|r| r.point).collect();
        let estimates = if points.is_empty() {
            Vec::new()
        } else {
            let radius = params.radius_m;
            // Cells at least as large as the radius: the 3 × 3 cells around a point's cell hold
            // every point within the radius.
            let cells = Cells::new(&points, |_, _| radius);
            let mut near: Vec<Neighbour> = Vec::with_capacity(64);
            points
                .iter()
                .map(|p| estimate_at(p, &cells, params, &mut near))
                .collect()
        };
        let unusable = estimates.iter().filter(|e| e.is_none()).count();
        Self {
            params: *params,
            points: estimates,
            unusable,
        }
    }

    /// The parameters of the estimates.
    pub fn params(&self) -> &SurfaceParams {
        &self.params
    }

    /// One estimate per return of the scan, in its order (`None`: no usable estimate).
    pub fn points(&self) -> &[Option<SurfacePoint>] {
        &self.points
    }

    /// Returns without a usable estimate.
    pub fn unusable(&self) -> usize {
        self.unusable
    }
}

/// A point near the one estimated: squared distance, index in the scan, position.
type Neighbour = (f64, u32, Point2<f64>);

/// The estimate at `p` from the points of `cells`; `near` is a reused buffer.
fn estimate_at(
    p: &Point2<f64>,
    cells: &Cells,
    params: &SurfaceParams,
    near: &mut Vec<Neighbour>,
) -> Option<SurfacePoint> {
    let radius_sq = params.radius_m * params.radius_m;
    let (cx, cy) = cells.cell_xy(p);
    let (x_lo, x_hi) = (cx.saturating_sub(1), (cx + 1).min(cells.nx - 1));
    near.clear();
    for y in cy.saturating_sub(1)..=(cy + 1).min(cells.ny - 1) {
        let range = cells.row((x_lo, x_hi), y);
        for (q, &id) in cells.points[range.clone()].iter().zip(&cells.ids[range]) {
            let d = (q - p).norm_squared();
            if d <= radius_sq {
                near.push((d, id, *q));
            }
        }
    }
    if near.len() < params.min_neighbours {
        return None;
    }
    // The nearest ones, ties by index, so the estimate does not depend on the cell order.
    let by_distance = |a: &Neighbour, b: &Neighbour| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
    if near.len() > params.max_neighbours {
        near.select_nth_unstable_by(params.max_neighbours - 1, by_distance);
        near.truncate(params.max_neighbours);
    }
    let k = near.len() as f64;
    let mean = near.iter().map(|&(_, _, q)| q.coords).sum::<Vector2<f64>>() / k;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for &(_, _, q) in near.iter() {
        let d = q.coords - mean;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    let (sxx, sxy, syy) = (sxx / k, sxy / k, syy / k);
    // Eigen-decomposition of the symmetric 2 × 2 scatter in closed form.
    let half_trace = 0.5 * (sxx + syy);
    let radius = (0.25 * (sxx - syy).powi(2) + sxy * sxy).sqrt();
    let (lambda_t, lambda_n) = (half_trace + radius, (half_trace - radius).max(0.0));
    if lambda_t.is_nan() || lambda_t <= 0.0 || lambda_n > params.max_thickness_ratio * lambda_t {
        return None;
    }
    // The along-surface direction: an eigenvector of λ_t, from whichever row is better scaled.
    let t = if sxx >= syy {
        Vector2::new(lambda_t - syy, sxy)
    } else {
        Vector2::new(sxy, lambda_t - sxx)
    };
    let t = t / t.norm();
    let mut normal = Vector2::new(-t.y, t.x);
    if normal.dot(&p.coords) > 0.0 {
        normal = -normal;
    }
    let across = lambda_n.max(params.min_variance_ratio * lambda_t);
    Some(SurfacePoint {
        normal,
        covariance: t * t.transpose() * lambda_t + normal * normal.transpose() * across,
        mean: Point2::from(mean),
    })
}
