//! `icp_bench.variants()` and `icp_bench.kinds()`: the built-in variants and the registry's
//! stage families, kinds and parameters, as `icp-eval list` shows them.

use icp_core::variants::{builtin_names, builtins, section_docs, stage_families};
use pyo3::prelude::*;

use crate::convert::to_python;

/// The names of the built-in variants, in order.
#[pyfunction]
pub fn variants() -> Vec<String> {
    builtin_names()
}

/// The registry as data: `variants` (each built-in's `name` and `source`), `families` (each
/// stage family's `name`, `summary` and `kinds`, each kind with its `summary` and
/// `parameters`: `name`, `type_name`, `default`, `description`) and `sections` (the parts of
/// a variant that are not stages, with their parameters).
#[pyfunction]
pub fn kinds(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    let variants: Vec<serde_json::Value> = builtins()
        .into_iter()
        .map(|v| serde_json::json!({ "name": v.name, "source": v.source }))
        .collect();
    to_python(
        py,
        &serde_json::json!({
            "variants": variants,
            "families": stage_families(),
            "sections": section_docs(),
        }),
    )
}
