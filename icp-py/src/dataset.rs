//! `icp_bench.load(uri) -> Dataset`: a dataset through the loader registry (the URIs of
//! `icp-eval run --dataset`), its scans and reference as numpy arrays.

use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;

use crate::convert::to_python;
use crate::errors::{dataset_error, DataError};

/// A loaded dataset: scans, timestamps, the reference, the sensor model and what the loader
/// noticed.
#[pyclass(frozen, module = "icp_bench")]
pub struct Dataset {
    pub(crate) inner: datasets::Dataset,
}

#[pymethods]
impl Dataset {
    /// The dataset's name (from its provenance).
    #[getter]
    fn name(&self) -> &str {
        &self.inner.provenance.name
    }

    /// One `(n, 2)` float64 array per scan: `range_m, bearing_rad` of its valid returns (the
    /// no-return readings dropped), in acquisition order.
    #[getter]
    fn scans<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyArray2<f64>>>> {
        self.inner
            .scans
            .iter()
            .map(|scan| {
                let rows: Vec<Vec<f64>> = scan
                    .returns()
                    .iter()
                    .map(|r| vec![r.range_m, r.bearing_rad])
                    .collect();
                if rows.is_empty() {
                    return Ok(PyArray2::zeros(py, [0, 2], false));
                }
                PyArray2::from_vec2(py, &rows).map_err(|e| DataError::new_err(e.to_string()))
            })
            .collect()
    }

    /// Each scan's time, seconds: its own timestamp, else its index times `dt_s` (as the
    /// reports time it).
    #[getter]
    fn timestamps<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let times: Vec<f64> = (0..self.inner.scans.len())
            .map(|k| eval::data::scan_time_s(&self.inner, k))
            .collect();
        PyArray1::from_vec(py, times)
    }

    /// The nominal time between scans, seconds.
    #[getter]
    fn dt_s(&self) -> f64 {
        self.inner.dt_s
    }

    /// The reference pose of each scan as an `(n, 3)` array of `x_m, y_m, heading_rad` (the
    /// heading as the source gives it, growing in `reference_heading_sense`), or None.
    #[getter]
    fn reference<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
        let Some(poses) = &self.inner.reference else {
            return Ok(None);
        };
        let rows: Vec<Vec<f64>> = poses
            .iter()
            .map(|p| vec![p.x_m, p.y_m, p.heading_rad])
            .collect();
        if rows.is_empty() {
            return Ok(Some(PyArray2::zeros(py, [0, 3], false)));
        }
        PyArray2::from_vec2(py, &rows)
            .map(Some)
            .map_err(|e| DataError::new_err(e.to_string()))
    }

    /// What the reference is (e.g. `ground truth`), or None without a reference.
    #[getter]
    fn reference_kind(&self) -> Option<String> {
        self.inner.reference_kind.map(|k| k.to_string())
    }

    /// The sense in which the reference heading grows: `counter_clockwise` or `clockwise`.
    #[getter]
    fn reference_heading_sense<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.inner.reference_heading_sense)
    }

    /// The sense in which the scanner's bearings grow (for `motion`).
    #[getter]
    fn bearing_sense<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.inner.bearing_sense)
    }

    /// The sensor's error model as a dict (what `register(sensor=...)` takes):
    /// `sigma_r_const_m` (metres), `sigma_r_per_m` (metres per metre of range) and
    /// `sigma_alpha_rad` (radians); `σ_r = sigma_r_const_m + sigma_r_per_m · range`.
    #[getter]
    fn sensor<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.inner.sensor)
    }

    /// What the loader noticed, one sentence each.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.inner.warnings.iter().map(|w| w.to_string()).collect()
    }

    fn __len__(&self) -> usize {
        self.inner.scans.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "Dataset({:?}, {} scans, reference: {})",
            self.inner.provenance.name,
            self.inner.scans.len(),
            self.inner
                .reference_kind
                .map_or_else(|| "none".to_owned(), |k| k.to_string())
        )
    }
}

/// Loads the dataset `uri` (`KIND:TARGET?KEY=VALUE&...`, as `icp-eval run --dataset` takes it,
/// e.g. `synthetic:marina-like?scans=20` or `carmen:/data/aces.log.gz`).
#[pyfunction]
pub fn load(py: Python<'_>, uri: &str) -> PyResult<Dataset> {
    let inner = py
        .detach(|| datasets::source::open(uri))
        .map_err(dataset_error)?;
    Ok(Dataset { inner })
}
