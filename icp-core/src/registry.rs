//! Stage kinds by name: the one composition model of icp-core.
//!
//! A registration method is a chain of stages (Algorithm 1 of Naus & Marchel 2019): selection,
//! matching, error metric, pair weighting, robust rejection and minimisation. Each stage has a
//! *family* (a trait: `select::Selection`, `matching::Matcher`, `metric::Metric`,
//! `weighting::PairWeighting`, `robust::RobustKernel`, `minimize::Minimizer`; each family's
//! module depends on this one, never the other way) and *kinds* (its
//! implementations). A kind is registered once, as one line in its family's [`Family`] list,
//! with a [`Kind`]: its name, a one-line summary with its citation, its typed parameters (a
//! serde struct with units in the field names, defaults and a `validate`), and how it is built.
//! Configuration files, `icp-eval list`, the command line's help and every configuration error
//! are generated from these lists (libpointmatcher's registry with linfa's checked
//! parameters), so they cannot go stale.
//!
//! In a configuration file a stage is written `{"kind": "<name>", <parameters>...}`, or just
//! `"<name>"` when every parameter takes its default ([`StageSpec`]).

use std::fmt;
use std::marker::PhantomData;

use schemars::JsonSchema;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use serde_json::{Map, Value};

pub use crate::error::ParamError;

use crate::error::ConfigError;
use crate::SensorModel;

/// One stage as configuration data: the name of its kind and its parameters.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StageSpec {
    /// The kind's registered name, e.g. `directional`.
    pub kind: String,
    /// The parameters, by name (missing ones take their defaults).
    pub params: Map<String, Value>,
}

impl StageSpec {
    /// A stage of kind `kind` with every parameter at its default.
    pub fn kind(kind: &str) -> Self {
        Self {
            kind: kind.to_owned(),
            params: Map::new(),
        }
    }

    /// A stage of kind `kind` with the parameters `params` (a serde struct).
    pub fn of(kind: &str, params: &impl Serialize) -> Self {
        let params = match serde_json::to_value(params) {
            Ok(Value::Object(map)) => map,
            _ => Map::new(),
        };
        Self {
            kind: kind.to_owned(),
            params,
        }
    }

    /// The stage with one parameter set.
    pub fn with(mut self, name: &str, value: impl Into<Value>) -> Self {
        self.params.insert(name.to_owned(), value.into());
        self
    }

    /// The spec of a stage written in user code and not registered: its Rust type's name as
    /// the kind (prefixed `user:`), so reports say what really ran.
    pub fn unregistered<T: ?Sized>() -> Self {
        Self::kind(&format!("user:{}", std::any::type_name::<T>()))
    }
}

impl Serialize for StageSpec {
    /// `{"kind": ..., parameters...}`, the kind first.
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = serializer.serialize_map(Some(self.params.len() + 1))?;
        map.serialize_entry("kind", &self.kind)?;
        for (k, v) in &self.params {
            map.serialize_entry(k, v)?;
        }
        map.end()
    }
}

impl<'de> Deserialize<'de> for StageSpec {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        match Value::deserialize(deserializer)? {
            Value::String(kind) => Ok(Self {
                kind,
                params: Map::new(),
            }),
            Value::Object(mut params) => match params.remove("kind") {
                Some(Value::String(kind)) => Ok(Self { kind, params }),
                Some(other) => Err(D::Error::custom(format!(
                    "a stage's \"kind\" must be a string, found {other}"
                ))),
                None => Err(D::Error::custom(
                    "a stage needs a \"kind\" (e.g. {\"kind\": \"grid\"}, or just \"grid\")",
                )),
            },
            other => Err(D::Error::custom(format!(
                "a stage is a kind name or {{\"kind\": ..., parameters...}}, found {other}"
            ))),
        }
    }
}

impl fmt::Display for StageSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.kind)?;
        if !self.params.is_empty() {
            let params: Vec<String> = self
                .params
                .iter()
                .map(|(k, v)| format!("{k} = {v}"))
                .collect();
            write!(f, " {{{}}}", params.join(", "))?;
        }
        Ok(())
    }
}

/// What building a stage may need besides its own parameters: the variant's sensor model
/// (eqs. 5, 8, 9), shared by the weights and the metrics that use it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildContext {
    /// The error model of both scans.
    pub sensor: SensorModel,
}

/// The typed parameters of a stage kind. Every field has a default (`#[serde(default)]` on the
/// struct), unknown fields are refused (`#[serde(deny_unknown_fields)]`), the field's doc
/// comment is its help text, and [`Params::validate`] rejects values outside the domain.
pub trait Params: Serialize + DeserializeOwned + Default + JsonSchema {
    /// `Err` naming the first parameter outside its domain.
    fn validate(&self) -> Result<(), ParamError> {
        Ok(())
    }
}

/// No parameters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct NoParams {}

impl Params for NoParams {}

/// One parameter of a kind, for help texts: generated from the parameter struct.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ParamDoc {
    /// Name, as written in a configuration file (units in the name).
    pub name: String,
    /// Its type or allowed values, e.g. `number` or `huber | tukey`.
    pub type_name: String,
    /// Its default value.
    pub default: Value,
    /// The parameter's doc comment.
    pub description: String,
}

/// A registered kind of stage whose trait object is `S` (e.g. `dyn PairWeighting`).
pub trait StageKind<S: ?Sized>: Send + Sync {
    /// The registered name.
    fn name(&self) -> &'static str;
    /// One line: what the stage does, with its citation.
    fn summary(&self) -> &'static str;
    /// Its parameters, with types, defaults and descriptions.
    fn parameters(&self) -> Vec<ParamDoc>;
    /// The parameters as given, checked and completed with their defaults.
    fn normalize(&self, params: &Map<String, Value>) -> Result<Map<String, Value>, String>;
    /// The stage, from checked parameters.
    fn build(&self, params: &Map<String, Value>, ctx: &BuildContext) -> Result<Box<S>, String>;
}

/// A kind with parameters `P`, building a `Box<S>`: what a stage file declares, e.g.
/// `pub const KIND: Kind<InverseRange, dyn PairWeighting> = Kind::new("inverse_range", "...", |p, _| Box::new(p));`
pub struct Kind<P, S: ?Sized> {
    name: &'static str,
    summary: &'static str,
    build: fn(P, &BuildContext) -> Box<S>,
    _params: PhantomData<fn() -> P>,
}

impl<P, S: ?Sized> Kind<P, S> {
    /// The kind `name`, summarised by `summary`, built by `build` from checked parameters.
    pub const fn new(
        name: &'static str,
        summary: &'static str,
        build: fn(P, &BuildContext) -> Box<S>,
    ) -> Self {
        Self {
            name,
            summary,
            build,
            _params: PhantomData,
        }
    }
}

impl<P: Params, S: ?Sized> Kind<P, S> {
    fn parse(&self, params: &Map<String, Value>) -> Result<P, String> {
        let p: P =
            serde_json::from_value(Value::Object(params.clone())).map_err(|e| e.to_string())?;
        p.validate().map_err(|e| e.to_string())?;
        Ok(p)
    }
}

impl<P: Params, S: ?Sized> StageKind<S> for Kind<P, S> {
    fn name(&self) -> &'static str {
        self.name
    }

    fn summary(&self) -> &'static str {
        self.summary
    }

    fn parameters(&self) -> Vec<ParamDoc> {
        param_docs::<P>()
    }

    fn normalize(&self, params: &Map<String, Value>) -> Result<Map<String, Value>, String> {
        match serde_json::to_value(self.parse(params)?) {
            Ok(Value::Object(map)) => Ok(map),
            Ok(other) => Err(format!("parameters serialize to {other}, not an object")),
            Err(e) => Err(e.to_string()),
        }
    }

    fn build(&self, params: &Map<String, Value>, ctx: &BuildContext) -> Result<Box<S>, String> {
        Ok((self.build)(self.parse(params)?, ctx))
    }
}

/// The parameter docs of `P`, from its JSON schema (doc comments) and its default value.
pub fn param_docs<P: Serialize + Default + JsonSchema>() -> Vec<ParamDoc> {
    let schema = schemars::schema_for!(P);
    let root = schema.as_value();
    let defaults = serde_json::to_value(P::default()).unwrap_or(Value::Null);
    let Some(properties) = root.get("properties").and_then(Value::as_object) else {
        return Vec::new();
    };
    properties
        .iter()
        .map(|(name, prop)| ParamDoc {
            name: name.clone(),
            type_name: type_name(root, prop),
            default: defaults.get(name).cloned().unwrap_or(Value::Null),
            // One line: a doc comment's line breaks are layout, not content.
            description: prop
                .get("description")
                .and_then(Value::as_str)
                .unwrap_or_default()
                .split_whitespace()
                .collect::<Vec<_>>()
                .join(" "),
        })
        .collect()
}

/// A schema's type in a few words: `number`, `integer`, `a | b` for an enum of strings.
fn type_name(root: &Value, schema: &Value) -> String {
    if let Some(reference) = schema.get("$ref").and_then(Value::as_str) {
        let name = reference.rsplit('/').next().unwrap_or_default();
        if let Some(def) = root.get("$defs").and_then(|d| d.get(name)) {
            return type_name(root, def);
        }
    }
    if let Some(values) = schema.get("enum").and_then(Value::as_array) {
        return values
            .iter()
            .map(|v| v.as_str().map_or_else(|| v.to_string(), str::to_owned))
            .collect::<Vec<_>>()
            .join(" | ");
    }
    for key in ["oneOf", "anyOf"] {
        if let Some(options) = schema.get(key).and_then(Value::as_array) {
            return options
                .iter()
                .map(|o| match o.get("const") {
                    Some(Value::String(s)) => s.clone(),
                    Some(v) => v.to_string(),
                    None => type_name(root, o),
                })
                .collect::<Vec<_>>()
                .join(" | ");
        }
    }
    match schema.get("type") {
        Some(Value::String(t)) => t.clone(),
        Some(Value::Array(ts)) => ts
            .iter()
            .filter_map(Value::as_str)
            .collect::<Vec<_>>()
            .join(" | "),
        _ => "value".to_owned(),
    }
}

/// Every registered kind of one stage family.
pub struct Family<S: ?Sized + 'static> {
    /// The family's name, as the key of a variant's configuration (e.g. `weighting`).
    pub name: &'static str,
    /// What the family does in Algorithm 1.
    pub summary: &'static str,
    /// The kinds, one registration line each.
    pub kinds: &'static [&'static dyn StageKind<S>],
}

impl<S: ?Sized + 'static> Family<S> {
    /// The kind registered as `name`.
    pub fn find(&self, name: &str) -> Result<&'static dyn StageKind<S>, ConfigError> {
        self.kinds
            .iter()
            .copied()
            .find(|k| k.name() == name)
            .ok_or_else(|| ConfigError::UnknownKind {
                family: self.name,
                kind: name.to_owned(),
                known: self.names().join(", "),
            })
    }

    /// The registered names, in registration order.
    pub fn names(&self) -> Vec<&'static str> {
        self.kinds.iter().map(|k| k.name()).collect()
    }

    /// `spec` checked, with every parameter written out (defaults included).
    pub fn normalize(&self, spec: &StageSpec) -> Result<StageSpec, ConfigError> {
        let kind = self.find(&spec.kind)?;
        let params = kind
            .normalize(&spec.params)
            .map_err(|why| self.bad(spec, why))?;
        Ok(StageSpec {
            kind: spec.kind.clone(),
            params,
        })
    }

    /// The stage `spec` describes.
    pub fn build(&self, spec: &StageSpec, ctx: &BuildContext) -> Result<Box<S>, ConfigError> {
        self.find(&spec.kind)?
            .build(&spec.params, ctx)
            .map_err(|why| self.bad(spec, why))
    }

    fn bad(&self, spec: &StageSpec, why: String) -> ConfigError {
        ConfigError::BadParameters {
            family: self.name,
            kind: spec.kind.clone(),
            why,
        }
    }

    /// The family's documentation: every kind with its summary and parameters.
    pub fn doc(&self) -> FamilyDoc {
        FamilyDoc {
            name: self.name,
            summary: self.summary,
            kinds: self
                .kinds
                .iter()
                .map(|k| KindDoc {
                    name: k.name(),
                    summary: k.summary(),
                    parameters: k.parameters(),
                })
                .collect(),
        }
    }
}

/// A family's documentation, for `icp-eval list` and help texts.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FamilyDoc {
    /// The family's key in a variant configuration.
    pub name: &'static str,
    /// What it does.
    pub summary: &'static str,
    /// Its kinds.
    pub kinds: Vec<KindDoc>,
}

/// A section of a variant's configuration that is not a stage (its parameters are one typed
/// struct), for `icp-eval list`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SectionDoc {
    /// The section's key in a variant configuration.
    pub name: &'static str,
    /// What it holds.
    pub summary: &'static str,
    /// Its parameters.
    pub parameters: Vec<ParamDoc>,
}

/// A kind's documentation.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct KindDoc {
    /// Registered name.
    pub name: &'static str,
    /// One line with its citation.
    pub summary: &'static str,
    /// Its parameters.
    pub parameters: Vec<ParamDoc>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A test family of boxed numbers.
    trait Number: Send + Sync {
        fn value(&self) -> f64;
    }

    /// Parameters of the test kind.
    #[derive(Clone, Debug, Serialize, Deserialize, JsonSchema)]
    #[serde(default, deny_unknown_fields)]
    struct ScaleParams {
        /// Factor applied to the sensor's range slope, dimensionless.
        factor: f64,
        /// Which end.
        side: Side,
    }

    #[derive(Clone, Copy, Debug, Serialize, Deserialize, JsonSchema)]
    #[serde(rename_all = "snake_case")]
    enum Side {
        Near,
        Far,
    }

    impl Default for ScaleParams {
        fn default() -> Self {
            Self {
                factor: 2.0,
                side: Side::Near,
            }
        }
    }

    impl Params for ScaleParams {
        fn validate(&self) -> Result<(), ParamError> {
            ParamError::check_positive("factor", self.factor)
        }
    }

    struct Scaled(f64);
    impl Number for Scaled {
        fn value(&self) -> f64 {
            self.0
        }
    }

    const SCALE: Kind<ScaleParams, dyn Number> =
        Kind::new("scale", "a test kind (nobody 2026)", |p, ctx| {
            Box::new(Scaled(p.factor * ctx.sensor.sigma_r_per_m))
        });
    const ONE: Kind<NoParams, dyn Number> = Kind::new("one", "one", |_, _| Box::new(Scaled(1.0)));
    static NUMBERS: Family<dyn Number> = Family {
        name: "number",
        summary: "test",
        kinds: &[&SCALE, &ONE],
    };

    fn ctx() -> BuildContext {
        BuildContext {
            sensor: SensorModel::sweep(),
        }
    }

    #[test]
    fn specs_read_from_a_name_or_a_map_and_write_as_a_map() {
        let a: StageSpec = serde_json::from_str(r#""one""#).unwrap();
        assert_eq!(a, StageSpec::kind("one"));
        let b: StageSpec = serde_json::from_str(r#"{"kind": "scale", "factor": 3}"#).unwrap();
        assert_eq!(b, StageSpec::kind("scale").with("factor", 3));
        assert_eq!(
            serde_json::to_string(&b).unwrap(),
            r#"{"kind":"scale","factor":3}"#
        );
        for bad in [r#"{"factor": 3}"#, r#"{"kind": 3}"#, "3"] {
            assert!(serde_json::from_str::<StageSpec>(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn kinds_build_validate_and_name_what_is_wrong() {
        let built = NUMBERS
            .build(&StageSpec::kind("scale").with("factor", 3.0), &ctx())
            .unwrap();
        assert!((built.value() - 3.0 * 0.004258).abs() < 1e-15);
        assert_eq!(
            NUMBERS
                .build(&StageSpec::kind("one"), &ctx())
                .unwrap()
                .value(),
            1.0
        );
        let err = |spec: StageSpec| NUMBERS.build(&spec, &ctx()).err().unwrap().to_string();
        assert_eq!(
            err(StageSpec::kind("two")),
            "unknown number kind \"two\": expected one of scale, one"
        );
        assert_eq!(
            err(StageSpec::kind("scale").with("factor", -1.0)),
            "number \"scale\": factor = -1: must be finite and positive"
        );
        assert!(
            err(StageSpec::kind("scale").with("facter", 1.0)).contains("unknown field `facter`")
        );
        assert!(err(StageSpec::kind("one").with("x", 1.0)).contains("unknown field `x`"));
        assert!(err(StageSpec::kind("scale").with("side", "middle")).contains("middle"));
    }

    #[test]
    fn normalizing_writes_out_the_defaults() {
        let spec = NUMBERS.normalize(&StageSpec::kind("scale")).unwrap();
        assert_eq!(
            spec,
            StageSpec::kind("scale")
                .with("factor", 2.0)
                .with("side", "near")
        );
    }

    #[test]
    fn docs_come_from_the_parameter_struct() {
        let doc = NUMBERS.doc();
        assert_eq!(doc.kinds.len(), 2);
        let params = &doc.kinds[0].parameters;
        assert_eq!(params.len(), 2);
        let factor = params.iter().find(|p| p.name == "factor").unwrap();
        assert_eq!(factor.type_name, "number");
        assert_eq!(factor.default, serde_json::json!(2.0));
        assert_eq!(
            factor.description,
            "Factor applied to the sensor's range slope, dimensionless."
        );
        let side = params.iter().find(|p| p.name == "side").unwrap();
        assert_eq!(side.type_name, "near | far");
        assert!(doc.kinds[1].parameters.is_empty());
    }
}
