//! A weighting scheme written in Python: each iteration the function gets one dict of numpy
//! arrays describing the pairs (with each return's σ_r and σ_α from the variant's sensor
//! model, eq. 8) and returns their weights (checked by icp-core: one per pair, finite, ≥ 0).
//! It runs under the GIL, so the Python calls of parallel registrations take turns; the rest
//! of the loop runs without it.

use icp_core::pairs::PairSet;
use icp_core::registry::StageSpec;
use icp_core::weighting::BatchWeighting;
use icp_core::SensorModel;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A Python function as a [`BatchWeighting`], reported as `python:<qualified name>` with the
/// variant it modifies.
pub struct PyWeighting {
    /// The function.
    func: Py<PyAny>,
    /// Its `__qualname__`.
    qualname: String,
    /// The built-in variant whose weighting it replaces.
    base_variant: String,
    /// The variant's sensor model (the run's, after `sensor=`): each return's σ in the dict.
    sensor: SensorModel,
}

impl PyWeighting {
    /// `func` (callable) replacing the weighting of `base_variant`, whose sensor model is
    /// `sensor`.
    pub fn new(func: &Bound<'_, PyAny>, base_variant: &str, sensor: SensorModel) -> PyResult<Self> {
        let qualname = func
            .getattr("__qualname__")
            .and_then(|q| q.extract::<String>())
            .or_else(|_| func.repr().map(|r| r.to_string()))?;
        Ok(Self {
            func: func.clone().unbind(),
            qualname,
            base_variant: base_variant.to_owned(),
            sensor,
        })
    }

    /// The pairs of `set` as the dict the function gets.
    fn arrays<'py>(
        &self,
        py: Python<'py>,
        set: &PairSet<'_>,
        iteration: usize,
    ) -> PyResult<Bound<'py, PyDict>> {
        let n = set.pairs.len();
        let mut columns: [Vec<f64>; NAMES.len()] = std::array::from_fn(|_| Vec::with_capacity(n));
        for (i, c) in set.pairs.iter().enumerate() {
            let (src, dst) = (&set.src[c.src], &set.dst[c.dst]);
            let moved = set.src_moved[c.src];
            let normal = set.dst_normal(i);
            let values = [
                src.range_m,
                dst.range_m,
                src.bearing_rad,
                dst.bearing_rad,
                moved.x,
                moved.y,
                dst.point.x,
                dst.point.y,
                normal.map_or(f64::NAN, |v| v.x),
                normal.map_or(f64::NAN, |v| v.y),
                self.sensor.sigma_r_m(src.range_m),
                self.sensor.sigma_r_m(dst.range_m),
                self.sensor.sigma_alpha_rad,
                self.sensor.sigma_alpha_rad,
            ];
            for (column, value) in columns.iter_mut().zip(values) {
                column.push(value);
            }
        }
        let dict = PyDict::new(py);
        for (name, column) in NAMES.iter().zip(columns) {
            dict.set_item(name, PyArray1::from_vec(py, column))?;
        }
        dict.set_item("rotation_rad", set.t_ref_src.rotation.angle())?;
        dict.set_item("iteration", iteration)?;
        Ok(dict)
    }
}

/// The arrays of the dict, in the order [`PyWeighting::arrays`] fills them.
const NAMES: [&str; 14] = [
    "src_range_m",
    "dst_range_m",
    "src_bearing_rad",
    "dst_bearing_rad",
    "src_x_m",
    "src_y_m",
    "dst_x_m",
    "dst_y_m",
    "normal_x",
    "normal_y",
    "src_sigma_r_m",
    "dst_sigma_r_m",
    "src_sigma_alpha_rad",
    "dst_sigma_alpha_rad",
];

impl BatchWeighting for PyWeighting {
    fn spec(&self) -> StageSpec {
        StageSpec::kind(&format!("python:{}", self.qualname))
            .with("base_variant", self.base_variant.as_str())
    }

    fn weigh_batch(
        &self,
        set: &PairSet<'_>,
        iteration: usize,
        out: &mut Vec<f64>,
    ) -> Result<(), String> {
        Python::attach(|py| {
            let pairs = self.arrays(py, set, iteration)?;
            let returned = self.func.bind(py).call1((pairs,))?;
            let numpy = py.import("numpy")?;
            let weights = numpy
                .call_method1("asarray", (returned, "float64"))?
                .cast_into::<PyArray1<f64>>()
                .map_err(|e| {
                    pyo3::exceptions::PyTypeError::new_err(format!(
                        "the weights must be a 1-D array of numbers: {e}"
                    ))
                })?;
            out.clear();
            out.extend(weights.readonly().as_array().iter());
            Ok(())
        })
        .map_err(|e: PyErr| {
            Python::attach(|py| {
                let kind = e
                    .get_type(py)
                    .name()
                    .map(|n| n.to_string())
                    .unwrap_or_else(|_| "exception".into());
                format!("{}: {kind}: {}", self.qualname, e.value(py))
            })
        })
    }
}
