//! Variants as data: a [`VariantSpec`] names the stages and parameters of one chain, read
//! from a configuration file or from the built-in variants, and builds an [`Icp`].
//!
//! The built-in variants are the configuration files of `configs/variants/`, compiled in: the
//! paper's Table 1 and the field's point-to-line and plane-to-plane methods.
//!
//! | name | metric | weights | rejection | source |
//! | --- | --- | --- | --- | --- |
//! | K_ICP | point-to-point | uniform | none | Naus & Marchel 2019, Table 1 |
//! | H_ICP | point-to-point | uniform | Huber | Table 1 |
//! | HM_ICP | point-to-point | mean error, eq. 13 | Huber | Table 1 |
//! | HD_ICP | point-to-point | directional, eq. 12 | Huber | Table 1 |
//! | IR_ICP | point-to-point | inverse range | Huber | the worked example of a new scheme |
//! | PL_ICP | point-to-line | uniform | Huber | Censi 2008; Chen & Medioni 1991 |
//! | HD_PL_ICP | point-to-line | eq. 9 along the normal | Huber | this project |
//! | GICP | plane-to-plane, surface covariances | uniform | Huber | Segal et al. 2009 |
//! | HD_GICP | plane-to-plane, surface + sensor covariances | uniform | Huber | Segal et al. 2009 with eq. 8 |

use serde_json::Value;

use crate::error::ConfigError;
use crate::icp::Icp;
use crate::matching::MATCHERS;
use crate::metric::METRICS;
use crate::minimize::MINIMIZERS;
use crate::moving::{Placement, MOVING};
use crate::registry::{param_docs, BuildContext, FamilyDoc, ParamError, SectionDoc, StageSpec};
use crate::robust::ROBUST_KERNELS;
use crate::select::SELECTIONS;
pub use crate::spec::{check_name, VariantSpec};
use crate::surface::SurfaceParams;
use crate::weighting::{Weighting, WEIGHTINGS};
use crate::{IcpError, SensorModel, Termination};

impl VariantSpec {
    /// Builds the chain this spec describes, checking every stage's kind and parameters, the
    /// sections, and that the minimiser can minimise the metric's cost.
    pub fn build(&self) -> Result<Icp, ConfigError> {
        check_name(&self.name)?;
        let section = |section: &'static str| {
            move |source: ParamError| ConfigError::Section { section, source }
        };
        self.sensor.validate().map_err(|e| match e {
            IcpError::InvalidParameter {
                name,
                value,
                reason,
            } => ConfigError::Section {
                section: "sensor",
                source: ParamError::new(name, value, reason),
            },
            other => ConfigError::Incompatible(other.to_string()),
        })?;
        self.surfaces.validate().map_err(section("surfaces"))?;
        self.termination
            .validate()
            .map_err(section("termination"))?;
        let ctx = BuildContext {
            sensor: self.sensor,
        };
        let metric = METRICS.build(&self.metric, &ctx)?;
        let minimizer_spec = self
            .minimizer
            .clone()
            .unwrap_or_else(|| metric.default_minimizer());
        let minimizer = MINIMIZERS.build(&minimizer_spec, &ctx)?;
        minimizer
            .check(metric.as_ref())
            .map_err(ConfigError::Incompatible)?;
        Ok(Icp {
            name: self.name.clone(),
            source: self.source.clone(),
            sensor: self.sensor,
            selection: SELECTIONS.build(&self.selection, &ctx)?,
            matcher: MATCHERS.build(&self.matcher, &ctx)?,
            surfaces: self.surfaces,
            metric,
            weighting: Weighting::Pair(WEIGHTINGS.build(&self.weighting, &ctx)?),
            robust: ROBUST_KERNELS.build(&self.robust, &ctx)?,
            minimizer,
            termination: self.termination,
            moving: MOVING.build(&self.moving, &ctx)?,
            jackknife: true,
        })
    }

    /// Checks every parameter before a run.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.build().map(|_| ())
    }

    /// The spec with every stage's parameters written out (defaults included) and the
    /// minimiser named: what a run reports as its configuration.
    pub fn normalized(&self) -> Result<VariantSpec, ConfigError> {
        use crate::Registrar;
        Ok(self.build()?.spec())
    }

    /// The spec with the parameter at `path` (`section.parameter`, e.g. `robust.c`,
    /// `sensor.sigma_alpha_rad`, `selection.seed`, or `matcher.kind` to change a stage's kind)
    /// set to `value`; `Ok(None)` when this variant has no such parameter (its robust kernel
    /// has no `c`, say), `Err` when the value is not valid there.
    pub fn with_param(&self, path: &str, value: Value) -> Result<Option<VariantSpec>, ConfigError> {
        let bad = |why: String| ConfigError::Incompatible(format!("{path}: {why}"));
        let (section, parameter) = path
            .split_once('.')
            .ok_or_else(|| bad("expected section.parameter".into()))?;
        let mut json = serde_json::to_value(self.normalized()?).map_err(|e| bad(e.to_string()))?;
        let Some(slot) = json.get_mut(section).and_then(|s| s.get_mut(parameter)) else {
            return Ok(None);
        };
        *slot = value;
        let changed: VariantSpec = serde_json::from_value(json).map_err(|e| bad(e.to_string()))?;
        if parameter == "kind" {
            // Another kind: its own parameters take their defaults.
            let mut spec = changed;
            let kind = |s: &StageSpec| StageSpec::kind(&s.kind);
            match section {
                "selection" => spec.selection = kind(&spec.selection),
                "matcher" => spec.matcher = kind(&spec.matcher),
                "metric" => {
                    spec.metric = kind(&spec.metric);
                    spec.minimizer = None;
                }
                "weighting" => spec.weighting = kind(&spec.weighting),
                "robust" => spec.robust = kind(&spec.robust),
                "minimizer" => spec.minimizer = spec.minimizer.as_ref().map(kind),
                "moving" => spec.moving = kind(&spec.moving),
                _ => {}
            }
            return Ok(Some(spec.normalized()?));
        }
        changed.validate()?;
        Ok(Some(changed))
    }
}

/// The registrations that place the neighbours of `variant`'s detector of moving returns when
/// it asks for [`Placement::PointToLine`] (`None` otherwise): PL_ICP's configuration
/// (point-to-line, Censi 2008) with `variant`'s error model, its detector `variant`'s placing
/// by these registrations themselves, named `placement`.
pub fn placement_chain(variant: &VariantSpec) -> Result<Option<VariantSpec>, ConfigError> {
    use crate::Registrar;
    let built = variant.build()?;
    let asks = built
        .moving()
        .is_some_and(|m| m.placement() == Placement::PointToLine);
    if !asks {
        return Ok(None);
    }
    let mut spec = builtin(POINT_TO_LINE).expect("PL_ICP is built in");
    spec.name = "placement".to_owned();
    spec.sensor = variant.sensor;
    spec.moving = variant.moving.clone();
    spec.moving.params.insert(
        "placement".to_owned(),
        serde_json::to_value(Placement::Own).expect("a unit variant serializes"),
    );
    spec.validate()?;
    Ok(Some(spec))
}

/// The built-in variant whose registrations place detectors' neighbours (point-to-line).
const POINT_TO_LINE: &str = "PL_ICP";

/// The built-in variants: the committed configuration files, compiled in. Adding one is one
/// file in `configs/variants/` and one line here.
const BUILTIN: [&str; 9] = [
    include_str!("../../configs/variants/k_icp.json"),
    include_str!("../../configs/variants/h_icp.json"),
    include_str!("../../configs/variants/hm_icp.json"),
    include_str!("../../configs/variants/hd_icp.json"),
    include_str!("../../configs/variants/ir_icp.json"),
    include_str!("../../configs/variants/pl_icp.json"),
    include_str!("../../configs/variants/hd_pl_icp.json"),
    include_str!("../../configs/variants/gicp.json"),
    include_str!("../../configs/variants/hd_gicp.json"),
];

/// The paper's four variants, in Table 1's order.
pub const TABLE1: [&str; 4] = ["K_ICP", "H_ICP", "HM_ICP", "HD_ICP"];

/// Every built-in variant, in order.
pub fn builtins() -> Vec<VariantSpec> {
    BUILTIN
        .iter()
        .map(|text| serde_json::from_str(text).expect("the built-in configuration files parse"))
        .collect()
}

/// Names of every built-in variant.
pub fn builtin_names() -> Vec<String> {
    builtins().into_iter().map(|v| v.name).collect()
}

/// The built-in variant `name` (case-insensitive).
pub fn builtin(name: &str) -> Option<VariantSpec> {
    builtins()
        .into_iter()
        .find(|v| v.name.eq_ignore_ascii_case(name))
}

/// The four variants of Table 1.
pub fn table1() -> Vec<VariantSpec> {
    TABLE1
        .iter()
        .map(|n| builtin(n).expect("the Table 1 names are built in"))
        .collect()
}

/// The built-in variant `name` with the error model `sensor`, built.
fn builtin_with(name: &str, sensor: SensorModel) -> Icp {
    let mut spec = builtin(name).expect("a built-in name");
    spec.sensor = sensor;
    spec.build().expect("the built-in variants build")
}

/// K_ICP: uniform weights, no rejection (the paper's stages: equal-count selection, exact
/// nearest-neighbour matching, weighted Kabsch).
pub fn k_icp() -> Icp {
    builtin_with("K_ICP", SensorModel::sweep())
}

/// H_ICP: K_ICP plus Huber rejection with `c = 2.0138`.
pub fn h_icp() -> Icp {
    builtin_with("H_ICP", SensorModel::sweep())
}

/// HM_ICP: H_ICP with mean-error weights (eq. 13) from `sensor`.
pub fn hm_icp(sensor: SensorModel) -> Icp {
    builtin_with("HM_ICP", sensor)
}

/// HD_ICP: H_ICP with directional weights (eq. 12) from `sensor`.
pub fn hd_icp(sensor: SensorModel) -> Icp {
    builtin_with("HD_ICP", sensor)
}

/// Every stage family with its kinds and parameters, and the sections that are not stages:
/// what `icp-eval list` prints.
pub fn stage_families() -> Vec<FamilyDoc> {
    vec![
        SELECTIONS.doc(),
        MATCHERS.doc(),
        METRICS.doc(),
        WEIGHTINGS.doc(),
        ROBUST_KERNELS.doc(),
        MINIMIZERS.doc(),
        MOVING.doc(),
    ]
}

/// The sections of a variant's configuration that are not stages.
pub fn section_docs() -> Vec<SectionDoc> {
    vec![
        SectionDoc {
            name: "surfaces",
            summary: "how the normal and covariance behind each return are estimated (PCA of its nearest returns)",
            parameters: param_docs::<SurfaceParams>(),
        },
        SectionDoc {
            name: "sensor",
            summary: "the error model of the returns (Naus & Marchel 2019, eqs. 5, 8, 9)",
            parameters: param_docs::<SensorModel>(),
        },
        SectionDoc {
            name: "termination",
            summary: "when the iteration stops (Alg. 1 step 6)",
            parameters: param_docs::<Termination>(),
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Registrar;

    #[test]
    fn builtins_build_and_report_their_own_configuration() {
        let names = builtin_names();
        assert_eq!(names.len(), BUILTIN.len());
        for spec in builtins() {
            let built = spec.build().unwrap();
            assert_eq!(built.name(), spec.name);
            // The files are written out in full: what runs is what the file says.
            assert_eq!(built.spec(), spec, "{}", spec.name);
            assert!(spec.source.is_some(), "{} cites its source", spec.name);
        }
        assert!(builtin("x_icp").is_none());
        assert_eq!(builtin("hd_icp").unwrap().name, "HD_ICP");
        assert_eq!(table1().len(), 4);
        fn send_sync<T: Send + Sync>() {}
        send_sync::<Icp>();
        send_sync::<Box<dyn Registrar>>();
    }

    #[test]
    fn the_placement_chain_is_point_to_line_with_the_variants_sensor_and_detector() {
        let mut gicp = builtin("GICP").unwrap();
        gicp.sensor.sigma_r_per_m = 0.01;
        gicp.moving.params.insert("lag_scans".into(), 5.into());
        let chain = placement_chain(&gicp)
            .unwrap()
            .expect("GICP places by point-to-line");
        let pl_icp = builtin("PL_ICP").unwrap();
        assert_eq!(chain.metric, pl_icp.metric);
        assert_eq!(chain.robust, pl_icp.robust);
        assert_eq!(chain.sensor, gicp.sensor);
        let built = chain.build().unwrap();
        let detector = built.moving().expect("the chain detects");
        assert_eq!(detector.placement(), Placement::Own);
        assert_eq!(detector.lag_scans(), 5);
        // Its own placement, or no detector: no chain.
        assert!(placement_chain(&chain).unwrap().is_none());
        assert!(placement_chain(&builtin("HD_ICP").unwrap())
            .unwrap()
            .is_none());
    }

    #[test]
    fn invalid_specs_are_refused_naming_the_parameter() {
        let err = |f: &dyn Fn(&mut VariantSpec)| {
            let mut spec = builtin("H_ICP").unwrap();
            f(&mut spec);
            spec.build()
                .err()
                .unwrap_or_else(|| panic!("{spec:?} refused"))
                .to_string()
        };
        assert_eq!(
            err(&|s| s.robust = s.robust.clone().with("c", -1.0)),
            "robust \"median_scaled\": c = -1: must be finite and positive"
        );
        assert_eq!(
            err(&|s| s.termination.max_iterations = 0),
            "termination.max_iterations = 0: at least one iteration is needed"
        );
        assert_eq!(
            err(&|s| s.weighting = StageSpec::kind("inverse_range").with("r0_m", 0.0)),
            "weighting \"inverse_range\": r0_m = 0: must be finite and positive"
        );
        assert_eq!(
            err(&|s| s.weighting = StageSpec::kind("directionl")),
            "unknown weighting kind \"directionl\": expected one of uniform, mean_error, \
             directional, normal_directional, inverse_range"
        );
        assert_eq!(
            err(&|s| s.metric = StageSpec::kind("point_to_line")),
            "minimizer weighted_kabsch solves the point-to-point cost only; metric \
             point_to_line needs gauss_newton"
        );
        assert_eq!(
            err(&|s| s.surfaces.radius_m = 0.0),
            "surfaces.radius_m = 0: must be finite and positive"
        );
        assert_eq!(
            err(&|s| s.sensor.sigma_r_per_m = -1.0),
            "sensor.sigma_r_per_m = -1: must be finite and non-negative"
        );
        assert!(
            err(&|s| s.metric = StageSpec::kind("point_to_line").with("gate", 1.0))
                .contains("unknown field `gate`")
        );
    }

    #[test]
    fn specs_read_from_json_with_defaults_and_refuse_unknown_fields() {
        let json = r#"{"name": "T_ICP", "weighting": "directional",
                       "robust": {"kind": "median_scaled", "kernel": "tukey", "c": 4.685}}"#;
        let spec: VariantSpec = serde_json::from_str(json).unwrap();
        assert_eq!(spec.matcher, StageSpec::kind("grid"));
        assert_eq!(spec.sensor, SensorModel::sweep());
        let full = spec.normalized().unwrap();
        assert_eq!(full.minimizer, Some(StageSpec::kind("weighted_kabsch")));
        assert_eq!(full.robust.params["scale_from"], "pair_distance");
        let typo = r#"{"name": "T", "weighting": "uniform", "robust": "none", "matchr": "brute"}"#;
        assert!(serde_json::from_str::<VariantSpec>(typo).is_err());
    }

    /// Every parameter with a domain is checked, by the kind or section that owns it, with a
    /// message naming it.
    #[test]
    fn each_kinds_parameters_are_validated() {
        let cases: [(&str, &str, Value, &str); 13] = [
            ("HD_GICP", "metric.max_pair_distance_m", 0.0.into(), "metric \"plane_to_plane\": max_pair_distance_m = 0: must be finite and positive"),
            ("PL_ICP", "metric.max_pair_distance_m", (-1.0).into(), "metric \"point_to_line\": max_pair_distance_m = -1: must be finite and positive"),
            ("HD_ICP", "metric.max_pair_distance_m", 0.0.into(), "metric \"point_to_point\": max_pair_distance_m = 0: must be finite and positive"),
            ("HD_PL_ICP", "weighting.power", 0.0.into(), "weighting \"normal_directional\": power = 0: must be finite and positive"),
            ("IR_ICP", "weighting.r0_m", (-2.0).into(), "weighting \"inverse_range\": r0_m = -2: must be finite and positive"),
            ("GICP", "minimizer.lm_lambda_start", 0.0.into(), "minimizer \"gauss_newton\": lm_lambda_start = 0: must be finite and positive"),
            ("GICP", "robust.c", 0.0.into(), "robust \"median_scaled\": c = 0: must be finite and positive"),
            ("GICP", "surfaces.min_neighbours", 2.into(), "surfaces.min_neighbours = 2: at least 3 points are needed for a line fit with a residual"),
            ("GICP", "surfaces.max_neighbours", 4.into(), "surfaces.max_neighbours = 4: must be at least min_neighbours"),
            ("GICP", "surfaces.radius_m", 0.0.into(), "surfaces.radius_m = 0: must be finite and positive"),
            ("GICP", "surfaces.max_thickness_ratio", 1.5.into(), "surfaces.max_thickness_ratio = 1.5: must be in (0, 1]"),
            ("GICP", "surfaces.min_variance_ratio", 0.0.into(), "surfaces.min_variance_ratio = 0: must be in (0, 1]"),
            ("GICP", "termination.update_translation_eps_m", (-1.0).into(), "termination.update_translation_eps_m = -1: must be finite and non-negative"),
        ];
        for (variant, path, value, message) in cases {
            let err = builtin(variant)
                .unwrap()
                .with_param(path, value)
                .expect_err(path)
                .to_string();
            assert_eq!(err, message, "{variant} {path}");
        }
        // A value of the wrong type names the parameter too.
        let err = builtin("GICP")
            .unwrap()
            .with_param("metric.covariance", "sensor".into())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("sensor") && err.contains("surface_and_sensor"),
            "{err}"
        );
    }

    #[test]
    fn parameters_are_set_by_path() {
        let hd = builtin("HD_ICP").unwrap();
        let c3 = hd.with_param("robust.c", 3.0.into()).unwrap().unwrap();
        assert_eq!(c3.robust.params["c"], 3.0);
        assert_eq!(hd.with_param("robust.nope", 3.0.into()).unwrap(), None);
        let k = builtin("K_ICP").unwrap();
        assert_eq!(k.with_param("robust.c", 3.0.into()).unwrap(), None);
        let kd = hd
            .with_param("matcher.kind", "kdtree".into())
            .unwrap()
            .unwrap();
        assert_eq!(kd.matcher, StageSpec::kind("kdtree"));
        assert!(hd.with_param("robust.c", (-1.0).into()).is_err());
        assert!(hd.with_param("robust", 1.0.into()).is_err());
        let pl = hd
            .with_param("metric.kind", "point_to_line".into())
            .unwrap()
            .unwrap();
        assert_eq!(pl.minimizer.unwrap().kind, "gauss_newton");
    }

    /// Every built-in's file in `configs/variants/` is its normalized form (the spec it
    /// builds, every parameter written out, pretty JSON): what runs is what the file says.
    /// With `ICP_WRITE_CONFIGS=1` the files that differ are rewritten instead (`ICP_WRITE_CONFIGS=1
    /// cargo test -p icp-core --lib configs_are_written_in_normalized_form`), e.g. after a
    /// kind gained a parameter.
    #[test]
    fn configs_are_written_in_normalized_form() {
        let crate_dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let dir = crate_dir.parent().unwrap().join("configs/variants");
        let write = std::env::var_os("ICP_WRITE_CONFIGS").is_some_and(|v| v == "1");
        let mut stale = Vec::new();
        for spec in builtins() {
            let path = dir.join(format!("{}.json", spec.name.to_lowercase()));
            let normalized =
                serde_json::to_string_pretty(&spec.normalized().unwrap()).unwrap() + "\n";
            let on_disk = std::fs::read_to_string(&path)
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            if on_disk == normalized {
                continue;
            }
            if write {
                std::fs::write(&path, &normalized)
                    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                eprintln!("rewrote {}", path.display());
            } else {
                stale.push(format!(
                    "{}: {}",
                    path.display(),
                    first_difference(&normalized, &on_disk)
                ));
            }
        }
        assert!(
            stale.is_empty(),
            "not in normalized form (rewrite with ICP_WRITE_CONFIGS=1 cargo test -p icp-core \
             --lib configs_are_written_in_normalized_form):\n{}",
            stale.join("\n")
        );
    }

    /// Where `actual` first departs from `expected`, line by line: `line N: - expected / +
    /// actual` (an absent line shown as `<end of file>`).
    fn first_difference(expected: &str, actual: &str) -> String {
        let (mut e, mut a) = (expected.lines(), actual.lines());
        for n in 1.. {
            match (e.next(), a.next()) {
                (None, None) => break,
                (x, y) if x == y => continue,
                (x, y) => {
                    let show = |l: Option<&str>| l.unwrap_or("<end of file>").to_owned();
                    return format!("line {n}:\n  - {}\n  + {}", show(x), show(y));
                }
            }
        }
        "the same lines, other line endings or final newline".to_owned()
    }

    #[test]
    fn first_difference_names_the_line() {
        assert_eq!(
            first_difference("{\n  \"a\": 1\n}\n", "{\n  \"a\": 2\n}\n"),
            "line 2:\n  -   \"a\": 1\n  +   \"a\": 2"
        );
        assert_eq!(
            first_difference("a\nb\n", "a\n"),
            "line 2:\n  - b\n  + <end of file>"
        );
        assert_eq!(
            first_difference("a\n", "a\r\n"),
            "the same lines, other line endings or final newline"
        );
    }

    #[test]
    fn every_family_documents_every_kind() {
        for section in section_docs() {
            assert!(!section.parameters.is_empty(), "{}", section.name);
            for p in &section.parameters {
                assert!(!p.description.is_empty(), "{}.{}", section.name, p.name);
            }
        }
        for family in stage_families() {
            for kind in &family.kinds {
                assert!(!kind.summary.is_empty(), "{}.{}", family.name, kind.name);
                for p in &kind.parameters {
                    assert!(
                        !p.description.is_empty(),
                        "{}.{}.{} has no doc comment",
                        family.name,
                        kind.name,
                        p.name
                    );
                }
            }
        }
    }
}
