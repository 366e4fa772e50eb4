//! What `icp-eval run` does to the built-in variants and to the dataset from its options
//! (`--matcher`, `--huber-c`, `--seed`, `--sensor`), shared by the command line and the
//! Python package (`icp_bench.run`), so both run the same chains on the same data.

use datasets::{Dataset, LoadWarning};
use icp_core::sensor::{SensorOverrideError, SensorOverrides};
use icp_core::variants::VariantSpec;
use icp_core::{ConfigError, SensorModel};

/// The options that apply to the built-in variants, where a variant has the parameter.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BuiltinOptions {
    /// Nearest-neighbour matcher kind (`matcher.kind`).
    pub matcher: Option<String>,
    /// Factor c of the robust threshold (`robust.c`).
    pub huber_c: Option<f64>,
    /// Seed of a random selection (`selection.seed`).
    pub seed: Option<u64>,
}

impl BuiltinOptions {
    /// The built-in `spec` for data of `sensor`, with these options.
    pub fn apply(
        &self,
        spec: VariantSpec,
        sensor: SensorModel,
    ) -> Result<VariantSpec, ConfigError> {
        let mut spec = VariantSpec { sensor, ..spec };
        let params: [(&str, Option<serde_json::Value>); 3] = [
            ("matcher.kind", self.matcher.as_deref().map(Into::into)),
            ("robust.c", self.huber_c.map(Into::into)),
            ("selection.seed", self.seed.map(Into::into)),
        ];
        for (path, value) in params {
            if let Some(value) = value {
                spec = spec.with_param(path, value)?.unwrap_or(spec);
            }
        }
        Ok(spec)
    }
}

/// `ds` with its sensor model overridden by `overrides` (`--sensor`). The model is the user's
/// where the overrides give it: a warning that it was assumed is updated, or dropped when
/// every value is given.
pub fn override_sensor(
    ds: &mut Dataset,
    overrides: &SensorOverrides,
) -> Result<(), SensorOverrideError> {
    ds.sensor = overrides.apply(ds.sensor)?;
    let whole = overrides.sigma_r_const_m.is_some()
        && overrides.sigma_r_per_m.is_some()
        && overrides.sigma_alpha_deg.is_some();
    let effective = ds.sensor;
    ds.warnings.retain_mut(|w| match w {
        LoadWarning::AssumedSensorModel { sensor, of } => {
            *sensor = effective;
            *of = format!("{of}, with --sensor's values");
            !whole
        }
        _ => true,
    });
    Ok(())
}
