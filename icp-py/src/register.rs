//! `icp_bench.register(source, reference, variant, init, sensor) -> Registration`: one pair
//! registered as the harness registers it (the variant's surface estimates of both scans,
//! then the chain from `init`), with the GIL released.

use eval::run::covariance::closed_form_inflation;
use eval::run::covariance::CovarianceMode;
use eval::run::extended;
use eval::run::status::PairStatus;
use icp_core::variants::{builtin, builtin_names, VariantSpec};
use icp_core::{Registrar, SensorModel};
use nalgebra::{Isometry2, Vector2};
use numpy::PyArray2;
use pyo3::prelude::*;
use pyo3::types::PyString;

use crate::convert::{from_python, scan_from_array, to_python};
use crate::errors::{config_error, icp_error, ConfigError, InputError};

/// The variant `variant` names (a built-in name, any case) or describes (a spec as a dict,
/// like a configuration file's).
pub fn variant_spec(variant: &Bound<'_, PyAny>) -> PyResult<VariantSpec> {
    if let Ok(name) = variant.cast::<PyString>() {
        let name = name.to_str()?;
        return builtin(name).ok_or_else(|| {
            ConfigError::new_err(format!(
                "unknown variant {name:?}: expected one of {}, or a variant spec as a dict",
                builtin_names().join(", ")
            ))
        });
    }
    from_python(variant, "variant spec")
}

/// `(tx_m, ty_m, theta_rad)` as a transform, finite.
fn isometry((tx_m, ty_m, theta_rad): (f64, f64, f64)) -> PyResult<Isometry2<f64>> {
    if !(tx_m.is_finite() && ty_m.is_finite() && theta_rad.is_finite()) {
        return Err(InputError::new_err(format!(
            "init = ({tx_m}, {ty_m}, {theta_rad}): must be finite"
        )));
    }
    Ok(Isometry2::new(Vector2::new(tx_m, ty_m), theta_rad))
}

/// The outcome of one registration of a source scan onto a reference scan.
#[pyclass(frozen, module = "icp_bench")]
pub struct Registration {
    variant: String,
    inner: icp_core::Registration,
    status: PairStatus,
}

#[pymethods]
impl Registration {
    /// The variant's name.
    #[getter]
    fn variant(&self) -> &str {
        &self.variant
    }

    /// `(tx_m, ty_m, theta_rad)`: metres, metres and radians (not degrees: `theta_deg` gives
    /// the rotation in degrees, as the repr prints it); maps source points into the reference
    /// scan's frame, the rotation from the scan frame's `+x` towards its `+y`.
    #[getter]
    fn t_ref_src(&self) -> (f64, f64, f64) {
        let t = &self.inner.t_ref_src;
        (t.translation.x, t.translation.y, t.rotation.angle())
    }

    /// The rotation of `t_ref_src` in degrees, as `pairs.csv`'s `theta_deg`.
    #[getter]
    fn theta_deg(&self) -> f64 {
        self.inner.t_ref_src.rotation.angle().to_degrees()
    }

    /// The `(3, 3)` covariance of `(tx m, ty m, theta rad)` as `icp-eval run` reports it under
    /// its default mode, `extended` (the closed form, inflated for HD_GICP, widened to its
    /// sector jackknife), or None (a metric without one, or a direction left unconstrained:
    /// see `covariance_unbounded`).
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        let c = self.inner.covariance?;
        let m = c.bounded()?;
        let rows: Vec<Vec<f64>> = (0..3)
            .map(|i| (0..3).map(|j| m[(i, j)]).collect())
            .collect();
        PyArray2::from_vec2(py, &rows).ok()
    }

    /// True when the final pairs leave a direction unconstrained (its variance unbounded).
    #[getter]
    fn covariance_unbounded(&self) -> bool {
        self.inner.covariance.is_some_and(|c| c.is_unbounded())
    }

    /// Minimisation steps taken.
    #[getter]
    fn iterations(&self) -> usize {
        self.inner.iterations
    }

    /// Why the loop stopped (`converged`, `small_update`, `repeated_matching`,
    /// `max_iterations`).
    #[getter]
    fn stop_reason<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.inner.stop)
    }

    /// True when the iteration settled before its limit.
    #[getter]
    fn converged(&self) -> bool {
        self.inner.converged()
    }

    /// The harness's verdict without a global check: `ok`, `degenerate` or `no_overlap`.
    #[getter]
    fn status<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.status.kind())
    }

    /// Why the status is not `ok`, with its figures (empty when it is).
    #[getter]
    fn status_reason(&self) -> String {
        self.status.to_string()
    }

    /// True when the final pairs barely constrain one direction (conditioning ratio below
    /// the harness's threshold).
    #[getter]
    fn degenerate(&self) -> bool {
        self.inner.conditioning.is_some_and(|c| c.degenerate())
    }

    /// True when too few final pairs are close: the scans do not see the same surfaces.
    #[getter]
    fn no_overlap(&self) -> bool {
        self.inner.no_overlap()
    }

    /// Smallest over largest eigenvalue of the Hessian at the solution, or None.
    #[getter]
    fn cond_ratio(&self) -> Option<f64> {
        self.inner.conditioning.map(|c| c.ratio)
    }

    /// The smaller of the fractions of source and reference points near the other scan.
    #[getter]
    fn overlap(&self) -> f64 {
        self.inner.overlap
    }

    /// Pairs the metric used at the solution.
    #[getter]
    fn n_pairs(&self) -> usize {
        self.inner.n_pairs
    }

    /// Pairs the metric could not use at the solution.
    #[getter]
    fn n_unusable(&self) -> usize {
        self.inner.n_unusable
    }

    /// Sum of the final pair weights of the last step.
    #[getter]
    fn weight_sum(&self) -> f64 {
        self.inner.weight_sum
    }

    /// Mean residual of the used pairs after the final estimate, metres.
    #[getter]
    fn mean_residual_m(&self) -> f64 {
        self.inner.mean_residual_m
    }

    fn __repr__(&self) -> String {
        let (x, y, t) = self.t_ref_src();
        format!(
            "Registration({}: t_ref_src=({x:.4} m, {y:.4} m, {:.4}°), {} iterations, {} pairs, {})",
            self.variant,
            t.to_degrees(),
            self.inner.iterations,
            self.inner.n_pairs,
            match &self.status {
                PairStatus::Ok => "ok".to_owned(),
                flagged => flagged.to_string(),
            }
        )
    }
}

/// Registers `source` (scan k) onto `reference` (scan k+1), each an `(n, 2)` float64 array of
/// `range_m, bearing_rad`, with `variant` (a built-in name or a spec as a dict) from `init`
/// `(tx_m, ty_m, theta_rad)` (default: the identity), the variant's sensor model replaced by
/// `sensor` (a dict like `Dataset.sensor`) when given.
#[pyfunction]
#[pyo3(signature = (source, reference, variant=None, init=None, sensor=None))]
pub fn register(
    py: Python<'_>,
    source: &Bound<'_, PyAny>,
    reference: &Bound<'_, PyAny>,
    variant: Option<&Bound<'_, PyAny>>,
    init: Option<(f64, f64, f64)>,
    sensor: Option<&Bound<'_, PyAny>>,
) -> PyResult<Registration> {
    let source = scan_from_array(source, "source")?;
    let reference = scan_from_array(reference, "reference")?;
    let mut spec = match variant {
        Some(v) => variant_spec(v)?,
        None => builtin("HD_GICP").expect("HD_GICP is built in"),
    };
    if let Some(sensor) = sensor {
        spec.sensor = from_python::<SensorModel>(sensor, "sensor")?;
    }
    let icp = spec.build().map_err(config_error)?;
    let init = init.map_or(Ok(Isometry2::identity()), isometry)?;
    let result = py.detach(|| icp.register(&source, &reference, init));
    let mut inner = result.map_err(icp_error)?;
    // The covariance as the reports give it under their default mode (`extended`: the closed
    // form, inflated where its model leaves noise out, widened to its jackknife). Without the
    // ambiguity term and flag of a run: they need the pair's likelihood grid, not built here.
    let inflation = closed_form_inflation(&icp.spec().metric);
    inner.covariance = extended::of_registration(&inner, CovarianceMode::Extended, inflation);
    Ok(Registration {
        variant: spec.name,
        status: PairStatus::of(&Ok(inner), None, None),
        inner,
    })
}
