//! `icp_bench`: the icp-bench variants from numpy, and weighting schemes written in Python run
//! through the evaluation harness. A thin layer over icp-core, datasets and eval: every
//! number comes from the same Rust code as `icp-eval`'s, and every error is a Python
//! exception (a `ValueError` or `OSError` subclass) with the Rust message.
//!
//! The GIL is released while scans are loaded and registered and while a run runs; a Python
//! weighting takes it back for each call.
#![forbid(unsafe_code)]

use pyo3::prelude::*;

mod convert;
mod dataset;
mod errors;
mod listing;
mod motion;
mod register;
mod run;
mod weighting;

/// The icp_bench module.
#[pymodule]
fn icp_bench(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_class::<dataset::Dataset>()?;
    m.add_class::<register::Registration>()?;
    m.add_function(wrap_pyfunction!(listing::variants, m)?)?;
    m.add_function(wrap_pyfunction!(listing::kinds, m)?)?;
    m.add_function(wrap_pyfunction!(dataset::load, m)?)?;
    m.add_function(wrap_pyfunction!(register::register, m)?)?;
    m.add_function(wrap_pyfunction!(motion::motion, m)?)?;
    m.add_function(wrap_pyfunction!(run::run, m)?)?;
    m.add_function(wrap_pyfunction!(run::compare, m)?)?;
    m.add("InputError", py.get_type::<errors::InputError>())?;
    m.add("ConfigError", py.get_type::<errors::ConfigError>())?;
    m.add("DataError", py.get_type::<errors::DataError>())?;
    m.add(
        "DataNotFoundError",
        py.get_type::<errors::DataNotFoundError>(),
    )?;
    m.add("OutputError", py.get_type::<errors::OutputError>())?;
    m.add("WeightingError", py.get_type::<errors::WeightingError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
