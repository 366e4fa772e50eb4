//! A sensitivity sweep's definition and measure: the parameter varied ([`SweepParam`]) and
//! each variant's error spread at each value ([`SweepPoint`]); `studies::sweep` runs it.

use icp_core::variants::VariantSpec;
use icp_core::ConfigError;
use serde::{Deserialize, Serialize};

use crate::measure::report::RunReport;

/// The parameter a sweep varies: any `section.parameter` of a variant's configuration (e.g.
/// `robust.c`, `sensor.sigma_r_per_m`, `surfaces.radius_m`), or one of two names in the
/// paper's units: `sigma_alpha_deg` (the bearing error of the weights' sensor model, degrees)
/// and `huber_c` (`robust.c`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(into = "String", try_from = "String")]
pub struct SweepParam {
    /// Name as written on the command line.
    pub name: String,
    /// Its path in a variant's configuration.
    pub path: String,
    /// Factor from the written value to the configuration's unit.
    pub scale: f64,
}

impl SweepParam {
    /// The parameter written `name`.
    pub fn parse(name: &str) -> Result<Self, String> {
        let (path, scale) = match name {
            "sigma_alpha_deg" => ("sensor.sigma_alpha_rad", std::f64::consts::PI / 180.0),
            "huber_c" => ("robust.c", 1.0),
            other if other.contains('.') => (other, 1.0),
            other => {
                return Err(format!(
                    "unknown sweep parameter {other:?}: expected sigma_alpha_deg, huber_c or \
                     section.parameter (e.g. robust.c)"
                ))
            }
        };
        Ok(Self {
            name: name.to_owned(),
            path: path.to_owned(),
            scale,
        })
    }

    /// `spec` with the parameter set to `value` (unchanged when the variant has no such
    /// parameter, e.g. `robust.c` without rejection).
    pub fn apply(&self, spec: &VariantSpec, value: f64) -> Result<VariantSpec, ConfigError> {
        Ok(spec
            .with_param(&self.path, (value * self.scale).into())?
            .unwrap_or_else(|| spec.clone()))
    }
}

impl From<SweepParam> for String {
    fn from(p: SweepParam) -> String {
        p.name
    }
}

impl TryFrom<String> for SweepParam {
    type Error = String;
    fn try_from(name: String) -> Result<Self, String> {
        Self::parse(&name)
    }
}

/// Parses `NAME=v1,v2,...`.
pub fn parse_sweep(text: &str) -> Result<(SweepParam, Vec<f64>), String> {
    let (name, values) = text
        .split_once('=')
        .ok_or_else(|| format!("expected NAME=v1,v2,... in {text:?}"))?;
    let param = SweepParam::parse(name.trim())?;
    let values = values
        .split(',')
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .map_err(|_| format!("{v:?} is not a number"))
        })
        .collect::<Result<Vec<_>, _>>()?;
    if values.is_empty() {
        return Err("a sweep needs at least one value".into());
    }
    Ok((param, values))
}

/// The error spread of one variant at one parameter value (pairs with a plausible reference).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepPoint {
    /// Parameter value.
    pub value: f64,
    /// Variant.
    pub variant: String,
    /// SOG error std, m/s.
    pub sog_std_mps: Option<f64>,
    /// SOG median |e|, m/s.
    pub sog_median_abs_mps: Option<f64>,
    /// ΔCOG error std, °.
    pub dcog_std_deg: Option<f64>,
    /// ΔCOG median |e|, °.
    pub dcog_median_abs_deg: Option<f64>,
}

/// A sweep's results.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepResult {
    /// The parameter varied.
    pub param: SweepParam,
    /// One point per value and variant.
    pub points: Vec<SweepPoint>,
}

/// The sweep's points at `value` from the run `report` made there.
pub fn points_of(value: f64, report: &RunReport) -> Vec<SweepPoint> {
    report
        .variants
        .iter()
        .map(|v| {
            let e = &v.plausible_reference;
            SweepPoint {
                value,
                variant: v.name.clone(),
                sog_std_mps: e.sog_err_mps.map(|s| s.std),
                sog_median_abs_mps: e.sog_err_mps.map(|s| s.median_abs),
                dcog_std_deg: e.dcog_err_deg.map(|s| s.std),
                dcog_median_abs_deg: e.dcog_err_deg.map(|s| s.median_abs),
            }
        })
        .collect()
}
