//! The paper's four variants (Table 1), and variants as data: a [`VariantSpec`] names the
//! stages and parameters of one chain, read from a configuration file or from the built-in
//! registry ([`builtin`]), and builds a [`Registrar`].
//!
//! | name | weights | rejection |
//! | --- | --- | --- |
//! | K_ICP | uniform | none |
//! | H_ICP | uniform | Huber |
//! | HM_ICP | mean error, eq. 13 | Huber |
//! | HD_ICP | directional, eq. 12 | Huber |
//! | IR_ICP | inverse range (the worked example of a new scheme) | Huber |

use serde::{Deserialize, Serialize};

use crate::matching::{BruteForce, Delaunay, Grid, KdTree, Matcher, MatcherKind};
use crate::minimize::WeightedKabsch;
use crate::robust::{Kernel, MedianScaled, NoRobust, RobustKernel};
use crate::select::{AllPoints, EqualCount, Selection};
use crate::weighting::{Directional, MeanError, Uniform, WeightingSpec};
use crate::{Icp, IcpError, Registrar, SensorModel, Termination};

/// K_ICP: uniform weights, no rejection.
pub type KIcp<M = Grid, S = EqualCount> = Icp<S, M, Uniform, NoRobust, WeightedKabsch>;
/// H_ICP: uniform weights, Huber rejection.
pub type HIcp<M = Grid, S = EqualCount> = Icp<S, M, Uniform, MedianScaled, WeightedKabsch>;
/// HM_ICP: mean-error weights (eq. 13), Huber rejection.
pub type HmIcp<M = Grid, S = EqualCount> = Icp<S, M, MeanError, MedianScaled, WeightedKabsch>;
/// HD_ICP: directional weights (eq. 12), Huber rejection.
pub type HdIcp<M = Grid, S = EqualCount> = Icp<S, M, Directional, MedianScaled, WeightedKabsch>;

fn chain<S, M, W, K>(
    name: &str,
    selection: S,
    matcher: M,
    weighting: W,
    robust: K,
    termination: Termination,
) -> Icp<S, M, W, K, WeightedKabsch> {
    Icp {
        name: name.to_owned(),
        selection,
        matcher,
        weighting,
        robust,
        minimizer: WeightedKabsch,
        termination,
    }
}

/// K_ICP with the paper's stages: equal-count selection (seed 0), nearest-neighbour matching
/// (on a grid: the same pairs as the paper's Delaunay search).
pub fn k_icp() -> KIcp {
    chain(
        "K_ICP",
        EqualCount::default(),
        Grid,
        Uniform,
        NoRobust,
        Termination::default(),
    )
}

/// H_ICP: K_ICP plus Huber rejection with `c = 2.0138`.
pub fn h_icp() -> HIcp {
    chain(
        "H_ICP",
        EqualCount::default(),
        Grid,
        Uniform,
        MedianScaled::paper_huber(),
        Termination::default(),
    )
}

/// HM_ICP: H_ICP with mean-error weights from `sensor`.
pub fn hm_icp(sensor: SensorModel) -> HmIcp {
    chain(
        "HM_ICP",
        EqualCount::default(),
        Grid,
        MeanError { sensor },
        MedianScaled::paper_huber(),
        Termination::default(),
    )
}

/// HD_ICP: H_ICP with directional weights from `sensor`.
pub fn hd_icp(sensor: SensorModel) -> HdIcp {
    chain(
        "HD_ICP",
        EqualCount::default(),
        Grid,
        Directional { sensor },
        MedianScaled::paper_huber(),
        Termination::default(),
    )
}

/// Point selection by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum SelectionKind {
    /// Every point of both scans.
    All,
    /// The paper's random equalisation of counts, seeded.
    EqualCount {
        /// Seed of the draw.
        seed: u64,
    },
}

impl Default for SelectionKind {
    fn default() -> Self {
        SelectionKind::EqualCount { seed: 0 }
    }
}

/// Robust rejection by name.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum RobustSpec {
    /// No rejection.
    None,
    /// A kernel with threshold `c · median d` ([`MedianScaled`]).
    MedianScaled {
        /// Huber, Tukey, Cauchy or Geman-McClure.
        kernel: Kernel,
        /// Factor on the median pair distance.
        c: f64,
    },
}

/// One registration method as data: what a configuration file holds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VariantSpec {
    /// Name in reports, e.g. `HD_ICP`.
    pub name: String,
    /// Where the method comes from (citation, Table 1 row), free text.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// Pair weighting (Alg. 1 step 3).
    pub weighting: WeightingSpec,
    /// Robust rejection (Alg. 1 step 4).
    pub robust: RobustSpec,
    /// Nearest-neighbour matcher (Alg. 1 step 2).
    #[serde(default)]
    pub matcher: MatcherKind,
    /// Point selection (Alg. 1 step 1).
    #[serde(default)]
    pub selection: SelectionKind,
    /// Error model for the weights.
    #[serde(default)]
    pub sensor: SensorModel,
    /// Convergence rule (Alg. 1 step 6).
    #[serde(default)]
    pub termination: Termination,
}

impl VariantSpec {
    /// Checks every parameter before a run.
    pub fn validate(&self) -> Result<(), IcpError> {
        self.sensor.validate()?;
        self.termination.validate()?;
        self.weighting.validate()?;
        if let RobustSpec::MedianScaled { c, .. } = self.robust {
            if !(c.is_finite() && c > 0.0) {
                return Err(IcpError::InvalidParameter {
                    name: "robust.c",
                    value: c,
                    reason: "must be finite and positive",
                });
            }
        }
        Ok(())
    }

    /// Builds the registrar this spec describes.
    pub fn build(&self) -> Result<Box<dyn Registrar>, IcpError> {
        self.validate()?;
        Ok(match self.matcher {
            MatcherKind::Kdtree => self.build_with(KdTree),
            MatcherKind::Delaunay => self.build_with(Delaunay),
            MatcherKind::Brute => self.build_with(BruteForce),
            MatcherKind::Grid => self.build_with(Grid),
        })
    }

    fn build_with<M: Matcher + PartialEq + Clone + 'static>(
        &self,
        matcher: M,
    ) -> Box<dyn Registrar> {
        let selection: Box<dyn Selection> = match self.selection {
            SelectionKind::All => Box::new(AllPoints),
            SelectionKind::EqualCount { seed } => Box::new(EqualCount { seed }),
        };
        let robust: Box<dyn RobustKernel> = match self.robust {
            RobustSpec::None => Box::new(NoRobust),
            RobustSpec::MedianScaled { kernel, c } => Box::new(MedianScaled { kernel, c }),
        };
        Box::new(chain(
            &self.name,
            selection,
            matcher,
            self.weighting.build(self.sensor),
            robust,
            self.termination,
        ))
    }
}

/// Settings shared by the built-in variants (the command line's options).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VariantConfig {
    /// Error model for the weights.
    pub sensor: SensorModel,
    /// Nearest-neighbour matcher.
    pub matcher: MatcherKind,
    /// Point selection.
    pub selection: SelectionKind,
    /// Factor `c` of the Huber threshold `kHu = c · median`.
    pub huber_c: f64,
    /// Convergence rule.
    pub termination: Termination,
}

impl Default for VariantConfig {
    fn default() -> Self {
        Self {
            sensor: SensorModel::sweep(),
            matcher: MatcherKind::Grid,
            selection: SelectionKind::default(),
            huber_c: MedianScaled::PAPER_C,
            termination: Termination::default(),
        }
    }
}

/// The paper's four variants, in Table 1's order.
pub const TABLE1: [&str; 4] = ["K_ICP", "H_ICP", "HM_ICP", "HD_ICP"];

/// The built-in variants: name, weighting, whether Huber rejects, and the source.
const BUILTIN: [(&str, WeightingSpec, bool, &str); 5] = [
    (
        "K_ICP",
        WeightingSpec::Uniform,
        false,
        "Naus & Marchel 2019, Table 1: uniform weights, no rejection",
    ),
    (
        "H_ICP",
        WeightingSpec::Uniform,
        true,
        "Naus & Marchel 2019, Table 1: uniform weights, Huber (c = 2.0138)",
    ),
    (
        "HM_ICP",
        WeightingSpec::MeanError,
        true,
        "Naus & Marchel 2019, Table 1 and eq. 13: mean-error weights, Huber",
    ),
    (
        "HD_ICP",
        WeightingSpec::Directional,
        true,
        "Naus & Marchel 2019, Table 1 and eq. 12: directional weights, Huber",
    ),
    (
        "IR_ICP",
        WeightingSpec::InverseRange { r0_m: 1.0 },
        true,
        "icp-bench worked example: inverse-range weights, Huber",
    ),
];

/// Names of every built-in variant.
pub fn builtin_names() -> impl Iterator<Item = &'static str> {
    BUILTIN.iter().map(|b| b.0)
}

/// The built-in variant `name` (case-insensitive) with the shared settings of `config`.
pub fn builtin(name: &str, config: &VariantConfig) -> Option<VariantSpec> {
    let &(name, weighting, huber, source) =
        BUILTIN.iter().find(|b| b.0.eq_ignore_ascii_case(name))?;
    Some(VariantSpec {
        name: name.to_owned(),
        source: Some(source.to_owned()),
        weighting,
        robust: if huber {
            RobustSpec::MedianScaled {
                kernel: Kernel::Huber,
                c: config.huber_c,
            }
        } else {
            RobustSpec::None
        },
        matcher: config.matcher,
        selection: config.selection,
        sensor: config.sensor,
        termination: config.termination,
    })
}

/// The four variants of Table 1 with the shared settings of `config`.
pub fn table1(config: &VariantConfig) -> Vec<VariantSpec> {
    TABLE1
        .iter()
        .map(|n| builtin(n, config).expect("the Table 1 names are built in"))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtins_build_and_stages_are_send_sync() {
        for name in builtin_names() {
            let spec = builtin(&name.to_lowercase(), &VariantConfig::default()).unwrap();
            assert_eq!(spec.name, name);
            assert_eq!(spec.build().unwrap().name(), name);
        }
        assert!(builtin("X_ICP", &VariantConfig::default()).is_none());
        assert_eq!(table1(&VariantConfig::default()).len(), 4);
        fn send_sync<T: Send + Sync>() {}
        send_sync::<KIcp>();
        send_sync::<HIcp>();
        send_sync::<HmIcp<Delaunay>>();
        send_sync::<HdIcp<BruteForce, AllPoints>>();
        send_sync::<Box<dyn Registrar>>();
    }

    #[test]
    fn invalid_specs_are_refused() {
        let mut spec = builtin("H_ICP", &VariantConfig::default()).unwrap();
        spec.robust = RobustSpec::MedianScaled {
            kernel: Kernel::Huber,
            c: -1.0,
        };
        assert!(matches!(
            spec.build(),
            Err(IcpError::InvalidParameter {
                name: "robust.c",
                ..
            })
        ));
        let mut spec = builtin("K_ICP", &VariantConfig::default()).unwrap();
        spec.termination.max_iterations = 0;
        assert!(spec.build().is_err());
        let mut spec = builtin("IR_ICP", &VariantConfig::default()).unwrap();
        spec.weighting = WeightingSpec::InverseRange { r0_m: 0.0 };
        assert!(spec.build().is_err());
    }

    #[test]
    fn specs_read_from_json_with_defaults_and_refuse_unknown_fields() {
        let json = r#"{"name": "T_ICP", "weighting": {"kind": "directional"},
                       "robust": {"kind": "median_scaled", "kernel": "tukey", "c": 4.685}}"#;
        let spec: VariantSpec = serde_json::from_str(json).unwrap();
        assert_eq!(spec.matcher, MatcherKind::Grid);
        assert_eq!(spec.sensor, SensorModel::sweep());
        assert!(spec.build().is_ok());
        let typo = r#"{"name": "T", "weighting": {"kind": "uniform"}, "robust": {"kind": "none"}, "matchr": "brute"}"#;
        assert!(serde_json::from_str::<VariantSpec>(typo).is_err());
    }

    #[test]
    fn the_spec_and_the_typed_constructor_register_identically() {
        let pts: Vec<[f64; 2]> = (0..200)
            .map(|i| {
                let a = i as f64 * 0.031;
                [
                    (8.0 + 3.0 * (2.0 * a).sin()) * a.cos(),
                    (8.0 + 3.0 * (2.0 * a).sin()) * a.sin(),
                ]
            })
            .collect();
        let t = nalgebra::Isometry2::new(nalgebra::Vector2::new(0.2, -0.1), 0.02);
        let moved: Vec<[f64; 2]> = pts
            .iter()
            .map(|p| {
                let q = t * nalgebra::Point2::new(p[0], p[1]);
                [q.x + 0.01 * (q.y * 7.0).sin(), q.y]
            })
            .collect();
        let (a, b) = (
            crate::Scan::from_cartesian(&pts).unwrap(),
            crate::Scan::from_cartesian(&moved).unwrap(),
        );
        let id = nalgebra::Isometry2::identity();
        let typed = hd_icp(SensorModel::sweep()).register(&a, &b, id).unwrap();
        let spec = builtin("HD_ICP", &VariantConfig::default())
            .unwrap()
            .build()
            .unwrap()
            .register(&a, &b, id)
            .unwrap();
        assert_eq!(typed, spec);
    }
}
