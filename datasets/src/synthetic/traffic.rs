//! The rough harbour's traffic as a user names it (`icp-eval synth --boats`,
//! `synthetic:rough?boats=`): `none`, a harbour without boats, or a JSON file holding a list
//! of boats, each an object with exactly the fields of [`Boat`]:
//!
//! ```json
//! [{"length_m": 6.0, "beam_m": 2.4, "lane_m": -4.0, "start_s": -20.0, "rate": 1.5}]
//! ```
//!
//! (`configs/boats/harbour.json` holds the built-in three, [`Boat::harbour`]). Lengths and
//! beams must be finite and positive, the rest finite; an empty list is a harbour without
//! boats. Boats apply to the rough scenario only.

use std::path::{Path, PathBuf};

use super::rough::{Boat, Rough};
use super::{generate, generate_corridor, Corridor, Scenario};
use crate::{Dataset, DatasetError, FileProvenance};

/// The value that names a rough harbour without boats (a file so named is `./none`).
pub const NO_BOATS: &str = "none";

/// Why boats cannot be used: each names the file, and the boat and field where one is wrong.
#[derive(Debug, thiserror::Error)]
pub enum BoatsError {
    /// Boats given for a scenario without the rough harbour.
    #[error(
        "boats: the {scenario:?} scenario has no moving boats to replace (boats apply to the \
         rough scenario only)"
    )]
    NotRough {
        /// The scenario's name.
        scenario: String,
    },
    /// The file cannot be read.
    #[error("cannot read the boats file {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The file is not a JSON list of boats (not JSON, a missing or unknown field, a value
    /// that is not a number).
    #[error("{path}:{line}:{column}: not a list of boats: {what}")]
    Json {
        /// The file.
        path: PathBuf,
        /// Line of the error, from 1.
        line: usize,
        /// Column of the error, from 1.
        column: usize,
        /// What the JSON reader found.
        what: String,
    },
    /// A boat with a field out of its domain.
    #[error("{path}: boats[{index}].{field} = {value}: {reason}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// The boat's position in the list, from 0.
        index: usize,
        /// The field.
        field: &'static str,
        /// Its value.
        value: f64,
        /// What it must be.
        reason: &'static str,
    },
}

/// The boats of a JSON file (see the module documentation), each valid, and the file's
/// provenance (its path and sha256).
pub fn read_boats(path: &Path) -> Result<(Vec<Boat>, FileProvenance), BoatsError> {
    let bytes = std::fs::read(path).map_err(|source| BoatsError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let boats: Vec<Boat> = serde_json::from_slice(&bytes).map_err(|e| BoatsError::Json {
        path: path.to_path_buf(),
        line: e.line(),
        column: e.column(),
        what: e.to_string(),
    })?;
    if let Some((index, (field, value, reason))) = boats
        .iter()
        .enumerate()
        .find_map(|(i, b)| b.invalid().map(|bad| (i, bad)))
    {
        return Err(BoatsError::Invalid {
            path: path.to_path_buf(),
            index,
            field,
            value,
            reason,
        });
    }
    Ok((boats, FileProvenance::of(path.to_path_buf(), &bytes)))
}

/// [`generate`], with the rough harbour's boats replaced by those `boats` names when given:
/// [`NO_BOATS`], or the path of a JSON file ([`read_boats`]) whose path and sha256 join the
/// dataset's description and provenance. Refused for a scenario without the rough harbour.
pub fn generate_with_boats(
    scenario: &Scenario,
    boats: Option<&str>,
) -> Result<Dataset, DatasetError> {
    let Some(named) = boats else {
        return generate(scenario);
    };
    let rough = scenario
        .rough
        .as_ref()
        .ok_or_else(|| BoatsError::NotRough {
            scenario: scenario.name.clone(),
        })?;
    let (boats, file) = if named == NO_BOATS {
        (Vec::new(), None)
    } else {
        let (boats, file) = read_boats(Path::new(named))?;
        (boats, Some(file))
    };
    let mut ds = generate(&Scenario {
        rough: Some(Rough {
            boats,
            ..rough.clone()
        }),
        ..scenario.clone()
    })?;
    if let Some(file) = file {
        ds.provenance.description += &format!(
            "; boats from {} (sha256 {})",
            file.path.display(),
            file.sha256
        );
        ds.provenance.files.push(file);
    }
    Ok(ds)
}

/// [`generate_corridor`], refusing boats when `boats` names any: the corridor has walking
/// people, not boats.
pub fn generate_corridor_without_boats(
    corridor: &Corridor,
    boats: Option<&str>,
) -> Result<Dataset, DatasetError> {
    if boats.is_some() {
        return Err(BoatsError::NotRough {
            scenario: Corridor::NAME.to_owned(),
        }
        .into());
    }
    generate_corridor(corridor)
}
