//! The LIDAR error model of Naus & Marchel (2019), Section 2: eqs. 5, 8 and 9.

use nalgebra::{Matrix2, Point2, Vector2};
use serde::{Deserialize, Serialize};

use crate::IcpError;

/// Range and bearing standard deviations of a 2D LIDAR, `σ_r(r) = σ_r0 + k·r` and `σ_α`.
///
/// The default is the Scanse Sweep of the paper: `σ_r = 0.004258·r` (Naus & Marchel 2019,
/// Section 3) and `σ_α = 0.5°` (the Sweep manual's beam divergence: the paper prints no usable
/// value, see `PAPER.md`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SensorModel {
    /// Constant part of the range standard deviation, metres.
    pub sigma_r_const_m: f64,
    /// Range-proportional part of the range standard deviation, metres per metre.
    pub sigma_r_per_m: f64,
    /// Bearing standard deviation, radians.
    pub sigma_alpha_rad: f64,
}

impl Default for SensorModel {
    fn default() -> Self {
        Self::sweep()
    }
}

impl SensorModel {
    /// Range-proportional error of the Scanse Sweep used by the paper, m/m.
    pub const SWEEP_SIGMA_R_PER_M: f64 = 0.004258;
    /// Bearing error of the Scanse Sweep (beam divergence), degrees.
    pub const SWEEP_SIGMA_ALPHA_DEG: f64 = 0.5;

    /// The Scanse Sweep: `σ_r = 0.004258·r`, `σ_α = 0.5°`.
    pub fn sweep() -> Self {
        Self {
            sigma_r_const_m: 0.0,
            sigma_r_per_m: Self::SWEEP_SIGMA_R_PER_M,
            sigma_alpha_rad: Self::SWEEP_SIGMA_ALPHA_DEG.to_radians(),
        }
    }

    /// The Sweep model with another bearing error, degrees.
    pub fn sweep_with_sigma_alpha_deg(sigma_alpha_deg: f64) -> Result<Self, IcpError> {
        let m = Self {
            sigma_alpha_rad: sigma_alpha_deg.to_radians(),
            ..Self::sweep()
        };
        m.validate()?;
        Ok(m)
    }

    /// Checks that every σ is finite and non-negative and that both `σ_α` and `σ_r(r)` are
    /// positive for `r > 0`, so that the weights of eqs. 11–13 are finite.
    pub fn validate(&self) -> Result<(), IcpError> {
        let fields = [
            ("sigma_r_const_m", self.sigma_r_const_m),
            ("sigma_r_per_m", self.sigma_r_per_m),
            ("sigma_alpha_rad", self.sigma_alpha_rad),
        ];
        for (name, value) in fields {
            if !value.is_finite() || value < 0.0 {
                return Err(IcpError::InvalidParameter {
                    name,
                    value,
                    reason: "must be finite and non-negative",
                });
            }
        }
        if self.sigma_alpha_rad == 0.0 {
            return Err(IcpError::InvalidParameter {
                name: "sigma_alpha_rad",
                value: 0.0,
                reason: "must be positive: a zero bearing error makes the weights infinite",
            });
        }
        if self.sigma_r_const_m == 0.0 && self.sigma_r_per_m == 0.0 {
            return Err(IcpError::InvalidParameter {
                name: "sigma_r_per_m",
                value: 0.0,
                reason: "sigma_r(r) must be positive: set sigma_r_const_m or sigma_r_per_m",
            });
        }
        Ok(())
    }

    /// Range standard deviation `σ_r(r)`, metres.
    #[inline]
    pub fn sigma_r_m(&self, range_m: f64) -> f64 {
        self.sigma_r_const_m + self.sigma_r_per_m * range_m
    }

    /// Standard deviation of the difference of two independent bearings, `√2 σ_α`, rad: what
    /// separates the same direction as two scans saw it.
    #[inline]
    pub fn bearing_difference_sd_rad(&self) -> f64 {
        std::f64::consts::SQRT_2 * self.sigma_alpha_rad
    }

    /// Squared mean position error `M² = (σ_α r)² + σ_r²`, m² (eq. 5).
    #[inline]
    pub fn mean_error_sq(&self, range_m: f64) -> f64 {
        let across = self.sigma_alpha_rad * range_m;
        let along = self.sigma_r_m(range_m);
        across * across + along * along
    }

    /// Covariance of the point `(r cos α, r sin α)`, m² (eq. 8):
    /// `σ_r² u_r u_rᵀ + (σ_α r)² u_t u_tᵀ` with `u_r = (cos α, sin α)`, `u_t = (−sin α, cos α)`.
    pub fn covariance(&self, range_m: f64, bearing_rad: f64) -> Matrix2<f64> {
        let (s, c) = bearing_rad.sin_cos();
        let u_r = Vector2::new(c, s);
        let u_t = Vector2::new(-s, c);
        let along = self.sigma_r_m(range_m);
        let across = self.sigma_alpha_rad * range_m;
        u_r * u_r.transpose() * (along * along) + u_t * u_t.transpose() * (across * across)
    }

    /// The covariance of eq. 8 at the return whose point is `point` and range `range_m`,
    /// without trigonometry: the beam direction `u_r` is `point / range`.
    #[inline]
    pub fn covariance_at(&self, point: &Point2<f64>, range_m: f64) -> Matrix2<f64> {
        let along = self.sigma_r_m(range_m);
        if range_m.is_nan() || range_m <= 0.0 {
            // A return at the sensor has no direction: σ_r(0) every way, and no bearing
            // error (σ_α · 0). Without this, the unit vector below is NaN.
            return Matrix2::identity() * (along * along);
        }
        let u = point.coords / range_m;
        let across = self.sigma_alpha_rad * range_m;
        let (a2, c2) = (along * along, across * across);
        // σ_r² u uᵀ + (σ_α r)² u⊥ u⊥ᵀ, with u⊥ = (−u_y, u_x).
        let xy = (a2 - c2) * u.x * u.y;
        Matrix2::new(
            a2 * u.x * u.x + c2 * u.y * u.y,
            xy,
            xy,
            a2 * u.y * u.y + c2 * u.x * u.x,
        )
    }

    /// Variance of the point's position along the direction `β`, m² (eq. 9, matrix form
    /// `S_β Cov S_βᵀ` with `S_β = [cos β, sin β]`; the printed expansion has typesetting slips).
    pub fn directional_variance(&self, range_m: f64, bearing_rad: f64, beta_rad: f64) -> f64 {
        let (s, c) = beta_rad.sin_cos();
        let s_beta = Vector2::new(c, s);
        (s_beta.transpose() * self.covariance(range_m, bearing_rad) * s_beta)[(0, 0)]
    }
}

impl SensorModel {
    /// Eq. 9 in the beam frame: the variance along a direction whose angle to the beam has
    /// cosine² `cos2`: `σ_r² cos² + (σ_α r)² (1 − cos²)`. The same number as
    /// [`SensorModel::directional_variance`] without any trigonometry (the covariance of eq. 8 is
    /// diagonal in the beam frame, with `σ_r²` along the beam and `(σ_α r)²` across it).
    #[inline]
    pub fn directional_variance_cos2(&self, range_m: f64, cos2: f64) -> f64 {
        let along = self.sigma_r_m(range_m);
        let across = self.sigma_alpha_rad * range_m;
        along * along * cos2 + across * across * (1.0 - cos2)
    }
}

/// Overrides of some of a [`SensorModel`]'s σ, written `key=value,key=value` with the keys
/// [`SensorOverrides::KEYS`] (`sigma_r_const_m=0.01,sigma_r_per_m=0,sigma_alpha_deg=0.25`):
/// each key at most once, any subset of them, values in the key's unit. [`apply`] sets them on
/// a base model and checks the result.
///
/// [`apply`]: SensorOverrides::apply
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SensorOverrides {
    /// Constant part of the range standard deviation, metres.
    pub sigma_r_const_m: Option<f64>,
    /// Range-proportional part of the range standard deviation, metres per metre.
    pub sigma_r_per_m: Option<f64>,
    /// Bearing standard deviation, degrees.
    pub sigma_alpha_deg: Option<f64>,
}

/// Why a sensor override string or its result is refused.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum SensorOverrideError {
    /// Nothing was written.
    #[error("empty sensor override: expected key=value[,key=value...] with keys {}", SensorOverrides::KEYS.join(", "))]
    Empty,
    /// An item without `=`.
    #[error("{item:?} is not key=value (keys: {})", SensorOverrides::KEYS.join(", "))]
    NotKeyValue {
        /// The item as written.
        item: String,
    },
    /// A key that is not one of [`SensorOverrides::KEYS`].
    #[error("unknown key {key:?}: expected one of {}", SensorOverrides::KEYS.join(", "))]
    UnknownKey {
        /// The key as written.
        key: String,
    },
    /// A value that does not parse as a number.
    #[error("{key} = {value:?} is not a number")]
    NotANumber {
        /// The key.
        key: &'static str,
        /// The value as written.
        value: String,
    },
    /// A key given twice.
    #[error("{key} is given twice")]
    Duplicate {
        /// The key.
        key: &'static str,
    },
    /// The model after the overrides fails [`SensorModel::validate`]; the key and value are in
    /// the override's units.
    #[error("{key} = {value}{}: {reason}", if *.from_base { " (the base model's)" } else { "" })]
    Invalid {
        /// The offending key.
        key: &'static str,
        /// Its value, in the key's unit.
        value: f64,
        /// Whether the value is the base model's rather than an override.
        from_base: bool,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// Any other refusal of [`SensorModel::validate`].
    #[error(transparent)]
    Model(IcpError),
}

impl SensorOverrides {
    /// The keys, in the order of [`SensorModel`]'s fields.
    pub const KEYS: [&'static str; 3] = ["sigma_r_const_m", "sigma_r_per_m", "sigma_alpha_deg"];

    /// `base` with the overridden σ replaced, if the result is a valid model
    /// ([`SensorModel::validate`]).
    pub fn apply(&self, base: SensorModel) -> Result<SensorModel, SensorOverrideError> {
        let model = SensorModel {
            sigma_r_const_m: self.sigma_r_const_m.unwrap_or(base.sigma_r_const_m),
            sigma_r_per_m: self.sigma_r_per_m.unwrap_or(base.sigma_r_per_m),
            sigma_alpha_rad: self
                .sigma_alpha_deg
                .map_or(base.sigma_alpha_rad, f64::to_radians),
        };
        match model.validate() {
            Ok(()) => Ok(model),
            Err(IcpError::InvalidParameter { name, reason, .. }) => {
                let (key, given, base_value) = match name {
                    "sigma_r_const_m" => (name, self.sigma_r_const_m, base.sigma_r_const_m),
                    "sigma_r_per_m" => (name, self.sigma_r_per_m, base.sigma_r_per_m),
                    _ => (
                        "sigma_alpha_deg",
                        self.sigma_alpha_deg,
                        base.sigma_alpha_rad.to_degrees(),
                    ),
                };
                Err(SensorOverrideError::Invalid {
                    key,
                    value: given.unwrap_or(base_value),
                    from_base: given.is_none(),
                    reason,
                })
            }
            Err(other) => Err(SensorOverrideError::Model(other)),
        }
    }
}

impl std::str::FromStr for SensorOverrides {
    type Err = SensorOverrideError;

    fn from_str(text: &str) -> Result<Self, SensorOverrideError> {
        if text.trim().is_empty() {
            return Err(SensorOverrideError::Empty);
        }
        let mut out = Self::default();
        for item in text.split(',') {
            let (key, value) =
                item.split_once('=')
                    .ok_or_else(|| SensorOverrideError::NotKeyValue {
                        item: item.trim().to_owned(),
                    })?;
            let key = key.trim();
            let (key, slot) = match key {
                "sigma_r_const_m" => ("sigma_r_const_m", &mut out.sigma_r_const_m),
                "sigma_r_per_m" => ("sigma_r_per_m", &mut out.sigma_r_per_m),
                "sigma_alpha_deg" => ("sigma_alpha_deg", &mut out.sigma_alpha_deg),
                other => {
                    return Err(SensorOverrideError::UnknownKey {
                        key: other.to_owned(),
                    })
                }
            };
            let value = value.trim();
            let number = value
                .parse::<f64>()
                .map_err(|_| SensorOverrideError::NotANumber {
                    key,
                    value: value.to_owned(),
                })?;
            if slot.replace(number).is_some() {
                return Err(SensorOverrideError::Duplicate { key });
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_return_at_the_sensor_has_a_finite_isotropic_covariance() {
        let m = SensorModel {
            sigma_r_const_m: 0.01,
            ..SensorModel::sweep()
        };
        let c = m.covariance_at(&Point2::origin(), 0.0);
        assert_eq!(c, Matrix2::identity() * 1e-4);
        let sweep = SensorModel::sweep().covariance_at(&Point2::origin(), 0.0);
        assert_eq!(sweep, Matrix2::zeros(), "σ_r(0) = 0 for the Sweep: no NaN");
    }

    #[test]
    fn covariance_at_a_point_is_eq_8_without_trigonometry() {
        let m = SensorModel {
            sigma_r_const_m: 0.01,
            ..SensorModel::sweep()
        };
        for i in 0..50 {
            let (r, a) = (0.5 + 0.8 * i as f64, -3.0 + 0.13 * i as f64);
            let p = Point2::new(r * a.cos(), r * a.sin());
            let (want, got) = (m.covariance(r, a), m.covariance_at(&p, r));
            assert!(
                (want - got).norm() <= 1e-14 * want.norm(),
                "{want} vs {got}"
            );
        }
    }
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    #[test]
    fn covariance_matches_monte_carlo_sample() {
        let model = SensorModel::sweep();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for &(r, alpha_deg) in &[(5.0, 0.0), (20.0, 37.0), (35.0, -121.0)] {
            let alpha: f64 = f64::to_radians(alpha_deg);
            let n_r = Normal::new(0.0, model.sigma_r_m(r)).unwrap();
            let n_a = Normal::new(0.0, model.sigma_alpha_rad).unwrap();
            let n = 200_000;
            let samples: Vec<Vector2<f64>> = (0..n)
                .map(|_| {
                    let (rr, aa) = (r + n_r.sample(&mut rng), alpha + n_a.sample(&mut rng));
                    Vector2::new(rr * aa.cos(), rr * aa.sin())
                })
                .collect();
            let mean = samples.iter().sum::<Vector2<f64>>() / n as f64;
            let cov = samples
                .iter()
                .map(|p| (p - mean) * (p - mean).transpose())
                .sum::<Matrix2<f64>>()
                / (n as f64 - 1.0);
            let expected = model.covariance(r, alpha);
            // Compare in the beam frame, where eq. 8 is diagonal: each variance is estimated
            // with a relative standard error of sqrt(2/n) = 0.32 %; 2 % is more than 6 sigma and
            // still catches a swapped or missing term (they differ by factors of 2 to 40).
            let rot = nalgebra::Rotation2::new(alpha).into_inner();
            let beam = rot.transpose() * cov * rot;
            let beam_expected = rot.transpose() * expected * rot;
            for i in 0..2 {
                let rel = (beam[(i, i)] - beam_expected[(i, i)]).abs() / beam_expected[(i, i)];
                assert!(
                    rel < 0.02,
                    "r={r} alpha={alpha_deg} axis {i}: rel err {rel}"
                );
            }
            let corr = beam[(0, 1)] / (beam[(0, 0)] * beam[(1, 1)]).sqrt();
            assert!(corr.abs() < 0.02, "beam-frame correlation {corr}");
            assert!((beam_expected[(0, 1)]).abs() < 1e-15);
        }
    }

    #[test]
    fn directional_variance_matches_closed_form() {
        // Independent computation: project each axis of the error ellipse on the direction.
        let model = SensorModel {
            sigma_r_const_m: 0.01,
            sigma_r_per_m: 0.004258,
            sigma_alpha_rad: 0.8f64.to_radians(),
        };
        for &(r, a, b) in &[
            (3.0f64, 0.1f64, 0.1f64),
            (12.0, 1.0, 2.5),
            (30.0, -2.0, 0.7),
            (7.0, 3.0, -3.0),
        ] {
            let along = model.sigma_r_m(r);
            let across = model.sigma_alpha_rad * r;
            let d = b - a;
            let expected = along * along * d.cos().powi(2) + across * across * d.sin().powi(2);
            let got = model.directional_variance(r, a, b);
            assert!(
                (got - expected).abs() <= 1e-15 * expected.max(1.0),
                "{got} vs {expected}"
            );
        }
        // Along the beam only σ_r counts, across it only σ_α r (the ellipse axes, eqs. 6, 7).
        let r = 10.0;
        let a = 0.3;
        assert!((model.directional_variance(r, a, a) - model.sigma_r_m(r).powi(2)).abs() < 1e-15);
        let across = (model.sigma_alpha_rad * r).powi(2);
        let perpendicular = a + std::f64::consts::FRAC_PI_2;
        assert!((model.directional_variance(r, a, perpendicular) - across).abs() < 1e-15);
        // Averaged over all directions σ_β² is M²/2 (eq. 5): trace of eq. 8 is M².
        assert!((model.covariance(r, a).trace() - model.mean_error_sq(r)).abs() < 1e-15);
    }

    #[test]
    fn beam_frame_form_equals_the_matrix_form() {
        let model = SensorModel {
            sigma_r_const_m: 0.02,
            ..SensorModel::sweep()
        };
        for i in 0..200 {
            let (r, a, b) = (
                0.5 + 0.2 * i as f64,
                0.37 * i as f64,
                -1.1 + 0.29 * i as f64,
            );
            let cos2 = (b - a).cos().powi(2);
            let fast = model.directional_variance_cos2(r, cos2);
            let matrix = model.directional_variance(r, a, b);
            assert!(
                (fast - matrix).abs() <= 1e-12 * matrix,
                "{fast} vs {matrix}"
            );
        }
    }

    #[test]
    fn validate_rejects_bad_parameters() {
        assert!(SensorModel::sweep().validate().is_ok());
        let bad = [
            SensorModel {
                sigma_alpha_rad: f64::NAN,
                ..SensorModel::sweep()
            },
            SensorModel {
                sigma_alpha_rad: 0.0,
                ..SensorModel::sweep()
            },
            SensorModel {
                sigma_r_per_m: -1.0,
                ..SensorModel::sweep()
            },
            SensorModel {
                sigma_r_per_m: 0.0,
                ..SensorModel::sweep()
            },
            SensorModel {
                sigma_r_const_m: f64::INFINITY,
                ..SensorModel::sweep()
            },
        ];
        for m in bad {
            assert!(
                matches!(m.validate(), Err(IcpError::InvalidParameter { .. })),
                "{m:?}"
            );
        }
    }

    #[test]
    fn sensor_overrides_set_any_subset_over_the_base() {
        let base = SensorModel::sweep();
        let all: SensorOverrides = " sigma_r_const_m=0.01, sigma_r_per_m=0 ,sigma_alpha_deg=0.25"
            .parse()
            .unwrap();
        let m = all.apply(base).unwrap();
        assert_eq!((m.sigma_r_const_m, m.sigma_r_per_m), (0.01, 0.0));
        assert_eq!(m.sigma_alpha_rad, 0.25f64.to_radians());
        let one: SensorOverrides = "sigma_alpha_deg=1".parse().unwrap();
        assert_eq!(
            one.apply(base).unwrap(),
            SensorModel {
                sigma_alpha_rad: 1f64.to_radians(),
                ..base
            }
        );
        assert_eq!(SensorOverrides::default().apply(base).unwrap(), base);
    }

    #[test]
    fn sensor_override_errors_name_the_key_and_the_problem() {
        let keys = "sigma_r_const_m, sigma_r_per_m, sigma_alpha_deg";
        let error = |text: &str| match text.parse::<SensorOverrides>() {
            Ok(o) => o
                .apply(SensorModel::sweep())
                .map_or_else(|e| e.to_string(), |m| format!("no error: {m:?}")),
            Err(e) => e.to_string(),
        };
        let cases = [
            (
                "",
                format!("empty sensor override: expected key=value[,key=value...] with keys {keys}"),
            ),
            (" ", format!("empty sensor override: expected key=value[,key=value...] with keys {keys}")),
            ("sigma_alpha_deg", format!("\"sigma_alpha_deg\" is not key=value (keys: {keys})")),
            ("sigma_alpha_deg=1,", format!("\"\" is not key=value (keys: {keys})")),
            ("sigma_alpha_rad=0.01", format!("unknown key \"sigma_alpha_rad\": expected one of {keys}")),
            ("sigma_r_per_m=abc", "sigma_r_per_m = \"abc\" is not a number".to_owned()),
            ("sigma_r_per_m=", "sigma_r_per_m = \"\" is not a number".to_owned()),
            ("sigma_alpha_deg=1,sigma_alpha_deg=2", "sigma_alpha_deg is given twice".to_owned()),
            ("sigma_alpha_deg=-1", "sigma_alpha_deg = -1: must be finite and non-negative".to_owned()),
            ("sigma_r_const_m=inf", "sigma_r_const_m = inf: must be finite and non-negative".to_owned()),
            ("sigma_r_const_m=NaN", "sigma_r_const_m = NaN: must be finite and non-negative".to_owned()),
            (
                "sigma_alpha_deg=0",
                "sigma_alpha_deg = 0: must be positive: a zero bearing error makes the weights infinite".to_owned(),
            ),
            (
                "sigma_r_per_m=0",
                "sigma_r_per_m = 0: sigma_r(r) must be positive: set sigma_r_const_m or sigma_r_per_m".to_owned(),
            ),
        ];
        for (text, expected) in cases {
            assert_eq!(error(text), expected, "{text:?}");
        }
        // A bad value of the base model is named as the base's.
        let bad_base = SensorModel {
            sigma_r_const_m: -1.0,
            ..SensorModel::sweep()
        };
        let e = "sigma_alpha_deg=1"
            .parse::<SensorOverrides>()
            .unwrap()
            .apply(bad_base)
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "sigma_r_const_m = -1 (the base model's): must be finite and non-negative"
        );
    }
}
