//! Conversions between Python objects and the Rust types: JSON-shaped data through Python's
//! `json` module (what the reports and configuration files hold), scans from numpy arrays.

use icp_core::Scan;
use numpy::{PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::errors::{ConfigError, InputError};

/// `value` as a Python object (dicts, lists, numbers, strings, None).
pub fn to_python<'py>(py: Python<'py>, value: &impl Serialize) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(|e| ConfigError::new_err(e.to_string()))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// The Python object `obj` (dicts, lists, numbers, strings) read as a `T`; `what` names it in
/// the error.
pub fn from_python<T: DeserializeOwned>(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<T> {
    let text: String = obj
        .py()
        .import("json")?
        .call_method1("dumps", (obj,))
        .and_then(|t| t.extract())
        .map_err(|e| ConfigError::new_err(format!("{what}: not JSON-like data: {e}")))?;
    serde_json::from_str(&text).map_err(|e| ConfigError::new_err(format!("{what}: {e}")))
}

/// The scan in `obj`, an `(n, 2)` float64 array of `range_m, bearing_rad` rows; `what` names
/// it in the error.
pub fn scan_from_array(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Scan> {
    let array: PyReadonlyArray2<'_, f64> = obj.extract().map_err(|_| {
        InputError::new_err(format!(
            "{what}: expected an (n, 2) float64 numpy array of range_m, bearing_rad; got {}",
            describe(obj)
        ))
    })?;
    if array.shape()[1] != 2 {
        return Err(InputError::new_err(format!(
            "{what}: expected an (n, 2) array of range_m, bearing_rad; got shape {:?}",
            array.shape()
        )));
    }
    let view = array.as_array();
    let (ranges_m, bearings_rad): (Vec<f64>, Vec<f64>) =
        view.rows().into_iter().map(|r| (r[0], r[1])).unzip();
    Scan::from_polar(&ranges_m, &bearings_rad)
        .map_err(|e| InputError::new_err(format!("{what}: {e}")))
}

/// What `obj` is, for an error: its type, and a numpy array's dtype and shape.
fn describe(obj: &Bound<'_, PyAny>) -> String {
    let type_name = obj
        .get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "?".into());
    match (obj.getattr("dtype"), obj.getattr("shape")) {
        (Ok(dtype), Ok(shape)) => format!("a {type_name} of dtype {dtype} and shape {shape}"),
        _ => format!("a {type_name}"),
    }
}
