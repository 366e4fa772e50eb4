//! `icp_bench.motion(...)`: SOG, ΔCOG, ROT and HDG of one registration (Naus & Marchel 2019,
//! eqs. 23–25) with their standard errors from its covariance.

use icp_core::motion::{BearingSense, MovementParams, MovementSigmas};
use nalgebra::{Isometry2, Matrix3, Vector2};
use numpy::{PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::{icp_error, ConfigError, InputError};

/// The movement parameters of the step `t_ref_src` `(tx_m, ty_m, theta_rad)` taken over
/// `dt_s` seconds from heading `heading_deg`, for a scanner whose bearings grow in
/// `bearing_sense` (`counter_clockwise` or `clockwise`, as `Dataset.bearing_sense`): a dict of
/// `sog_mps`, `dcog_deg`, `rot_dps`, `hdg_deg` and, given the `(3, 3)` `covariance` of
/// `(tx m, ty m, theta rad)`, their standard errors `sog_sigma_mps`, `dcog_sigma_deg`,
/// `rot_sigma_dps` and `hdg_sigma_deg` (the heading before the step taken as exact), else None.
#[pyfunction]
#[pyo3(signature = (t_ref_src, dt_s, heading_deg, covariance=None, bearing_sense="counter_clockwise"))]
pub fn motion<'py>(
    py: Python<'py>,
    t_ref_src: (f64, f64, f64),
    dt_s: f64,
    heading_deg: f64,
    covariance: Option<&Bound<'py, PyAny>>,
    bearing_sense: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let (tx_m, ty_m, theta_rad) = t_ref_src;
    let t = Isometry2::new(Vector2::new(tx_m, ty_m), theta_rad);
    if !(tx_m.is_finite() && ty_m.is_finite() && theta_rad.is_finite()) {
        return Err(InputError::new_err(format!(
            "t_ref_src = ({tx_m}, {ty_m}, {theta_rad}): must be finite"
        )));
    }
    let sense: BearingSense = serde_json::from_value(bearing_sense.into()).map_err(|_| {
        ConfigError::new_err(format!(
            "bearing_sense = {bearing_sense:?}: expected counter_clockwise or clockwise"
        ))
    })?;
    let params =
        MovementParams::from_registration(&t, dt_s, heading_deg, sense).map_err(icp_error)?;
    let sigmas = covariance
        .map(|c| MovementSigmas::propagate(&t, &matrix3(c)?, dt_s).map_err(icp_error))
        .transpose()?;
    let out = PyDict::new(py);
    out.set_item("sog_mps", params.sog_mps)?;
    out.set_item("dcog_deg", params.dcog_deg)?;
    out.set_item("rot_dps", params.rot_dps)?;
    out.set_item("hdg_deg", params.hdg_deg)?;
    out.set_item("sog_sigma_mps", sigmas.map(|s| s.sog_mps))?;
    out.set_item("dcog_sigma_deg", sigmas.map(|s| s.dcog_deg))?;
    out.set_item("rot_sigma_dps", sigmas.map(|s| s.rot_dps))?;
    // HDG = HDG₀ + ΔCOG with HDG₀ exact: the σ of ΔCOG.
    out.set_item("hdg_sigma_deg", sigmas.map(|s| s.dcog_deg))?;
    Ok(out)
}

/// A `(3, 3)` float64 array as a matrix.
fn matrix3(obj: &Bound<'_, PyAny>) -> PyResult<Matrix3<f64>> {
    let bad = || InputError::new_err("covariance: expected a (3, 3) float64 numpy array");
    let array: PyReadonlyArray2<'_, f64> = obj.extract().map_err(|_| bad())?;
    if array.shape() != [3, 3] {
        return Err(bad());
    }
    let view = array.as_array();
    Ok(Matrix3::from_fn(|i, j| view[(i, j)]))
}
