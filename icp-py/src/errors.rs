//! The package's exceptions: each a subclass of `ValueError` (bad input) or `OSError` (files),
//! carrying the Rust error's message.

use datasets::DatasetError;
use eval::error::EvalError;
use icp_core::{ConfigError as RustConfigError, IcpError};
use pyo3::create_exception;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::PyErr;

create_exception!(
    icp_bench,
    InputError,
    PyValueError,
    "Input a registration refuses: an array of the wrong shape or dtype, a NaN bearing, too \
     few points, a non-finite start or time step."
);
create_exception!(
    icp_bench,
    ConfigError,
    PyValueError,
    "An unknown variant, a variant spec or sensor model that does not build, or an option \
     outside its domain."
);
create_exception!(
    icp_bench,
    DataError,
    PyValueError,
    "A dataset URI or file whose content cannot be used (parse errors, bad values)."
);
create_exception!(
    icp_bench,
    DataNotFoundError,
    PyOSError,
    "A dataset file that is not there or cannot be read."
);
create_exception!(
    icp_bench,
    OutputError,
    PyOSError,
    "An output directory or file that cannot be written."
);
create_exception!(
    icp_bench,
    WeightingError,
    PyValueError,
    "A Python weighting that raised, or returned weights that are not one per pair, finite \
     and >= 0; the message names the variant, the pair and the iteration."
);

/// A registration's error: a configuration error, a weighting's failure, or bad input.
pub fn icp_error(e: IcpError) -> PyErr {
    match e {
        IcpError::Config(c) => ConfigError::new_err(c.to_string()),
        e @ IcpError::WeightingFailed { .. } => WeightingError::new_err(e.to_string()),
        e => InputError::new_err(e.to_string()),
    }
}

/// A variant that does not build.
pub fn config_error(e: RustConfigError) -> PyErr {
    ConfigError::new_err(e.to_string())
}

/// A dataset that cannot be loaded: missing files are `OSError`s, bad content `ValueError`s.
pub fn dataset_error(e: DatasetError) -> PyErr {
    match e {
        DatasetError::Io { .. } | DatasetError::NotFound { .. } => {
            DataNotFoundError::new_err(e.to_string())
        }
        e => DataError::new_err(e.to_string()),
    }
}

/// A harness error, by what it is about.
pub fn eval_error(e: EvalError) -> PyErr {
    match e {
        EvalError::Dataset(d) => dataset_error(d),
        EvalError::Icp(i) => icp_error(i),
        e @ (EvalError::Io { .. }
        | EvalError::OutputDir { .. }
        | EvalError::Serialize(_)
        | EvalError::Plot { .. }) => OutputError::new_err(e.to_string()),
        e @ EvalError::Estimates(_) => DataError::new_err(e.to_string()),
        e => ConfigError::new_err(e.to_string()),
    }
}
