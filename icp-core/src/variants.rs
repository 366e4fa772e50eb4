//! The four variants of the paper's Table 1 as named constructors of one [`Icp`] chain.
//!
//! | name | weights | Huber |
//! | --- | --- | --- |
//! | K_ICP | uniform | no |
//! | H_ICP | uniform | yes |
//! | HM_ICP | mean error, eq. 13 | yes |
//! | HD_ICP | directional, eq. 12 | yes |

use serde::{Deserialize, Serialize};

use crate::matching::{BruteForce, Delaunay, KdTree, Matcher, MatcherKind};
use crate::minimize::WeightedSvd;
use crate::robust::{HuberMedian, NoRobust};
use crate::select::{AllPoints, EqualCount, Selection};
use crate::weighting::{Directional, MeanError, Uniform};
use crate::{Icp, IcpError, Registrar, SensorModel, Termination};

/// K_ICP: uniform weights, no rejection.
pub type KIcp<M = KdTree, S = EqualCount> = Icp<S, M, Uniform, NoRobust, WeightedSvd>;
/// H_ICP: uniform weights, Huber rejection.
pub type HIcp<M = KdTree, S = EqualCount> = Icp<S, M, Uniform, HuberMedian, WeightedSvd>;
/// HM_ICP: mean-error weights (eq. 13), Huber rejection.
pub type HmIcp<M = KdTree, S = EqualCount> = Icp<S, M, MeanError, HuberMedian, WeightedSvd>;
/// HD_ICP: directional weights (eq. 12), Huber rejection.
pub type HdIcp<M = KdTree, S = EqualCount> = Icp<S, M, Directional, HuberMedian, WeightedSvd>;

fn chain<S, M, W, K>(
    name: &str,
    selection: S,
    matcher: M,
    weighting: W,
    robust: K,
    termination: Termination,
) -> Icp<S, M, W, K, WeightedSvd> {
    Icp {
        name: name.to_owned(),
        selection,
        matcher,
        weighting,
        robust,
        minimizer: WeightedSvd,
        termination,
    }
}

/// K_ICP with the paper's stages: equal-count selection (seed 0), k-d tree matching.
pub fn k_icp() -> KIcp {
    chain(
        "K_ICP",
        EqualCount::default(),
        KdTree,
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
        KdTree,
        Uniform,
        HuberMedian::default(),
        Termination::default(),
    )
}

/// HM_ICP: H_ICP with mean-error weights from `sensor`.
pub fn hm_icp(sensor: SensorModel) -> HmIcp {
    chain(
        "HM_ICP",
        EqualCount::default(),
        KdTree,
        MeanError { sensor },
        HuberMedian::default(),
        Termination::default(),
    )
}

/// HD_ICP: H_ICP with directional weights from `sensor`.
pub fn hd_icp(sensor: SensorModel) -> HdIcp {
    chain(
        "HD_ICP",
        EqualCount::default(),
        KdTree,
        Directional { sensor },
        HuberMedian::default(),
        Termination::default(),
    )
}

/// A variant of Table 1, by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum Variant {
    /// Uniform weights, no rejection.
    #[serde(rename = "K_ICP")]
    KIcp,
    /// Uniform weights, Huber.
    #[serde(rename = "H_ICP")]
    HIcp,
    /// Mean-error weights, Huber.
    #[serde(rename = "HM_ICP")]
    HmIcp,
    /// Directional weights, Huber.
    #[serde(rename = "HD_ICP")]
    HdIcp,
}

impl Variant {
    /// The four variants in Table 1's order.
    pub const ALL: [Variant; 4] = [Variant::KIcp, Variant::HIcp, Variant::HmIcp, Variant::HdIcp];

    /// The Table 1 name.
    pub fn name(self) -> &'static str {
        match self {
            Variant::KIcp => "K_ICP",
            Variant::HIcp => "H_ICP",
            Variant::HmIcp => "HM_ICP",
            Variant::HdIcp => "HD_ICP",
        }
    }

    /// Builds the variant with the stages and parameters of `config`.
    pub fn build(self, config: &VariantConfig) -> Result<Box<dyn Registrar>, IcpError> {
        config.validate()?;
        Ok(match config.matcher {
            MatcherKind::Kdtree => self.build_with(KdTree, config),
            MatcherKind::Delaunay => self.build_with(Delaunay, config),
            MatcherKind::Brute => self.build_with(BruteForce, config),
        })
    }

    fn build_with<M: Matcher + 'static>(
        self,
        matcher: M,
        config: &VariantConfig,
    ) -> Box<dyn Registrar> {
        let selection: Box<dyn Selection> = match config.selection {
            SelectionKind::All => Box::new(AllPoints),
            SelectionKind::EqualCount { seed } => Box::new(EqualCount { seed }),
        };
        let (name, term, sensor) = (self.name(), config.termination, config.sensor);
        let huber = HuberMedian { c: config.huber_c };
        match self {
            Variant::KIcp => Box::new(chain(name, selection, matcher, Uniform, NoRobust, term)),
            Variant::HIcp => Box::new(chain(name, selection, matcher, Uniform, huber, term)),
            Variant::HmIcp => Box::new(chain(
                name,
                selection,
                matcher,
                MeanError { sensor },
                huber,
                term,
            )),
            Variant::HdIcp => Box::new(chain(
                name,
                selection,
                matcher,
                Directional { sensor },
                huber,
                term,
            )),
        }
    }
}

impl std::fmt::Display for Variant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Variant {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Variant::ALL
            .into_iter()
            .find(|v| v.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| {
                format!("unknown variant {s:?}: expected K_ICP, H_ICP, HM_ICP or HD_ICP")
            })
    }
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

/// The parameters shared by the four variants.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VariantConfig {
    /// Error model for the HM and HD weights.
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
            matcher: MatcherKind::Kdtree,
            selection: SelectionKind::EqualCount { seed: 0 },
            huber_c: HuberMedian::PAPER_C,
            termination: Termination::default(),
        }
    }
}

impl VariantConfig {
    /// Checks every parameter before a run.
    pub fn validate(&self) -> Result<(), IcpError> {
        self.sensor.validate()?;
        self.termination.validate()?;
        if !(self.huber_c.is_finite() && self.huber_c > 0.0) {
            return Err(IcpError::InvalidParameter {
                name: "huber_c",
                value: self.huber_c,
                reason: "must be finite and positive",
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_stages_are_send_sync() {
        for v in Variant::ALL {
            assert_eq!(v.name().parse::<Variant>().unwrap(), v);
            assert_eq!(v.name().to_lowercase().parse::<Variant>().unwrap(), v);
            assert_eq!(v.build(&VariantConfig::default()).unwrap().name(), v.name());
        }
        assert!("X_ICP".parse::<Variant>().is_err());
        fn send_sync<T: Send + Sync>() {}
        send_sync::<KIcp>();
        send_sync::<HIcp>();
        send_sync::<HmIcp<Delaunay>>();
        send_sync::<HdIcp<BruteForce, AllPoints>>();
        send_sync::<Box<dyn Registrar>>();
    }

    #[test]
    fn invalid_config_is_refused() {
        let bad = VariantConfig {
            huber_c: -1.0,
            ..Default::default()
        };
        assert!(matches!(
            Variant::HIcp.build(&bad),
            Err(IcpError::InvalidParameter {
                name: "huber_c",
                ..
            })
        ));
        let bad = VariantConfig {
            termination: Termination {
                max_iterations: 0,
                mean_dist_change_eps_m: 1e-6,
            },
            ..Default::default()
        };
        assert!(Variant::KIcp.build(&bad).is_err());
    }
}
