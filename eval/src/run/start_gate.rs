//! The correspondence gate of a registration started close to the true motion.
//!
//! A local method started at the identity does not know how far the scans moved, so it cannot
//! gate its correspondences (the paper's variants have no gate). A start from the global search
//! ([`icp_core::global`]) is known to lie within about a cell of the best alignment, so a pair
//! much farther apart than that is not a correspondence: a fine registration from that start
//! refines within the search's uncertainty, as KISS-ICP's adaptive threshold (Vizzo et al.
//! 2023) gates at the expected error of its start. The reference start (`--init reference`, the
//! diagnostic of a perfect start) is gated alike, so that it measures the same method from a
//! better start; the other starts (identity, constant velocity, odometry) are not: how far
//! they are from the motion is not known.
//!
//! The gate's width, [`AUTO_CELLS`] cells of the search: the search's best pose is the centre
//! of a cell at the finest level (translation error at most half a cell diagonal, 0.71 cell)
//! and a rotation candidate moves the farthest return by at most one cell (the angular step
//! of Hess et al. 2016, so half a step at most half a cell): a true correspondence is at most
//! about 1.2 cells farther apart at the start than at the optimum. A second cell leaves room
//! for the returns' noise and the sampling of the surfaces. The factor was set from that
//! argument, not fitted; the measurements behind keeping it are in the doc of
//! [`AUTO_CELLS`].
//!
//! The gate applies to variants whose metric measures along a surface normal (point-to-line,
//! plane-to-plane) and that have no gate of their own. A point-to-point metric measures the
//! whole pair distance, which includes the offset along the surface between the two scans'
//! samples (half a beam spacing: 0.17 m at 40 m for 0.48° beams), so a fixed gate cuts
//! correct pairs at long range: it is not applied to them, and the paper's variants keep the
//! paper's loop whatever the start.

use std::fmt;
use std::str::FromStr;

use icp_core::global::GlobalParams;
use icp_core::metric::METRICS;
use icp_core::registry::BuildContext;
use icp_core::variants::VariantSpec;
use icp_core::ConfigError;
use serde::{Deserialize, Serialize};

/// The gate of a close start in cells of the search ([`GlobalParams::resolution_m`]): 0.2 m
/// with the default 0.1 m cells. Argued in the module doc, then measured with `--init global`
/// (success = within 0.1 m and 1° of the reference; the same runs with explicit gates of 0.2,
/// 0.3, 0.5 and 1 m): the CARMEN *aces* log, PL_ICP 59.9 % → 76.1 %, GICP 54.7 % → 69.7 %
/// (0.3 m: 74.0 %, 68.1 %; 1 m: 64.5 %, 57.9 %); the synthetic harbour (exact truth),
/// translation RMSE over the Cramér–Rao bound PL_ICP 1.25 → 1.21, GICP 1.10 → 1.10; marina,
/// plausible pairs, SOG median |e| and ΔCOG median |e| unchanged (0.019 m/s, 0.07°). The same
/// gate on the point-to-point HD_ICP costs it on the harbour (2.21 → 2.67 × bound), which is
/// why point-to-point metrics are left ungated.
pub const AUTO_CELLS: f64 = 2.0;

/// How registrations started close to the motion (the global search's pose, the reference)
/// gate their correspondences.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "mode", content = "gate_m", rename_all = "snake_case")]
pub enum StartGate {
    /// [`AUTO_CELLS`] cells of the search.
    #[default]
    Auto,
    /// No gate beyond the variant's own.
    Off,
    /// This distance, metres.
    Fixed(f64),
}

impl StartGate {
    /// The gate in metres for a search with `params`, `None` when off.
    pub fn metres(self, params: &GlobalParams) -> Option<f64> {
        match self {
            Self::Auto => Some(AUTO_CELLS * params.resolution_m),
            Self::Off => None,
            Self::Fixed(m) => Some(m),
        }
    }
}

impl FromStr for StartGate {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            t if t.eq_ignore_ascii_case("auto") => Ok(Self::Auto),
            t if t.eq_ignore_ascii_case("off") => Ok(Self::Off),
            t => match t.parse::<f64>() {
                Ok(m) if m.is_finite() && m > 0.0 => Ok(Self::Fixed(m)),
                _ => Err(format!(
                    "expected auto, off or a positive distance in metres, got {s:?}"
                )),
            },
        }
    }
}

impl fmt::Display for StartGate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Auto => f.write_str("auto"),
            Self::Off => f.write_str("off"),
            Self::Fixed(m) => write!(f, "{m}"),
        }
    }
}

/// The variant a close start of `spec` runs: `spec` with its metric's correspondence gate
/// set to `gate_m`, when the metric measures along a surface normal (it is not isotropic) and
/// has no gate of its own; `None` when the start changes nothing (the variant then runs as
/// it is).
pub fn gated(spec: &VariantSpec, gate_m: f64) -> Result<Option<VariantSpec>, ConfigError> {
    let metric = METRICS.build(
        &spec.metric,
        &BuildContext {
            sensor: spec.sensor,
        },
    )?;
    let ungated = spec
        .metric
        .params
        .get("max_pair_distance_m")
        .is_none_or(serde_json::Value::is_null);
    if metric.isotropic() || !ungated {
        return Ok(None);
    }
    spec.with_param("metric.max_pair_distance_m", gate_m.into())
}

#[cfg(test)]
mod tests {
    use icp_core::variants::builtin;

    use super::*;

    #[test]
    fn the_gate_parses_and_scales_with_the_search() {
        let params = GlobalParams::default();
        assert_eq!(
            "auto".parse::<StartGate>().unwrap().metres(&params),
            Some(AUTO_CELLS * params.resolution_m)
        );
        assert_eq!("OFF".parse::<StartGate>().unwrap().metres(&params), None);
        assert_eq!("0.35".parse::<StartGate>().unwrap(), StartGate::Fixed(0.35));
        for bad in ["0", "-1", "nan", "wide"] {
            assert!(bad.parse::<StartGate>().is_err(), "{bad}");
        }
    }

    #[test]
    fn surface_metrics_without_a_gate_get_it_and_point_to_point_does_not() {
        for name in ["PL_ICP", "HD_PL_ICP", "GICP", "HD_GICP"] {
            let twin = gated(&builtin(name).unwrap(), 0.2).unwrap().unwrap();
            assert_eq!(twin.metric.params["max_pair_distance_m"], 0.2, "{name}");
            assert_eq!(twin.name, name);
        }
        for name in ["K_ICP", "H_ICP", "HM_ICP", "HD_ICP"] {
            assert_eq!(gated(&builtin(name).unwrap(), 0.2).unwrap(), None, "{name}");
        }
        // A variant with a gate of its own keeps it.
        let own = builtin("PL_ICP")
            .unwrap()
            .with_param("metric.max_pair_distance_m", 0.5.into())
            .unwrap()
            .unwrap();
        assert_eq!(gated(&own, 0.2).unwrap(), None);
    }
}
