//! The loader registry: a dataset named by one string, `kind[:target][?key=value&...]`
//! (`carmen:aces.log.gz?fov_deg=180`, `rosbag:run/?scan=/front/scan&reference=/odom`), each
//! kind registered once in [`KINDS`] with its options and help text, so a command line's help
//! is generated from it ([`help`]) and adding a format is one entry here.
//!
//! Each kind's options become its own typed struct ([`crate::carmen::CarmenOptions`],
//! [`crate::rosbag::RosbagOptions`], ...); a bad option is a [`SourceError`] naming it.
//! Values are taken as written (no percent-decoding): a path holding `?` or `&` cannot be
//! named this way.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use crate::carmen::{self, CarmenOptions};
use crate::rosbag::{self, ReferenceChoice, RosbagOptions};
use crate::synthetic::{self, Corridor, Scenario};
use crate::{csvdir, marina, Dataset, DatasetError, ReferenceKind};

/// What a kind takes after `kind:`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// Nothing.
    None,
    /// An optional value, shown as this placeholder.
    Optional(&'static str),
    /// A required value, shown as this placeholder.
    Required(&'static str),
}

/// One option of a kind: `?name=value`.
#[derive(Clone, Copy, Debug)]
pub struct OptionDoc {
    /// The key.
    pub name: &'static str,
    /// The command-line flag that also sets it (`icp-eval run --dt`), if any.
    pub flag: Option<&'static str>,
    /// What it sets, with its default.
    pub help: &'static str,
}

/// A registered dataset kind.
pub struct Kind {
    /// The name before the `:`.
    pub name: &'static str,
    /// What follows the `:`.
    pub target: Target,
    /// One line on what the kind reads.
    pub summary: &'static str,
    /// Its options.
    pub options: &'static [OptionDoc],
    open: fn(&DatasetSource) -> Result<Dataset, DatasetError>,
}

impl Kind {
    /// `name`, `name[:X]` or `name:X`.
    pub fn syntax(&self) -> String {
        match self.target {
            Target::None => self.name.to_owned(),
            Target::Optional(p) => format!("{}[:{p}]", self.name),
            Target::Required(p) => format!("{}:{p}", self.name),
        }
    }
}

/// The first N scans of a source read from files (synthetic data generates N instead).
const SCANS: OptionDoc = OptionDoc {
    name: "scans",
    flag: Some("--scans"),
    help: "keep the first N scans, N >= 2 (more than there are: all of them, as the report says)",
};

/// Every dataset kind, in the order help lists them.
pub static KINDS: &[Kind] = &[
    Kind {
        name: "marina",
        target: Target::None,
        summary: "the paper's marina MATLAB files (found in data_dir, $ICP_DATA_DIR, ./datasets)",
        options: &[
            OptionDoc {
                name: "data_dir",
                flag: Some("--data-dir"),
                help: "directory of the files or of a marina/ folder",
            },
            OptionDoc {
                name: "dt_s",
                flag: Some("--dt"),
                help: "time between scans, s (default 1.0: the files have no timestamps)",
            },
            SCANS,
        ],
        open: open_marina,
    },
    Kind {
        name: "synthetic",
        target: Target::Optional("paper|marina-like|rough|corridor"),
        summary: "the simulated harbour, or office corridors (corridor), with exact ground \
                  truth (default scenario: paper)",
        options: &[
            OptionDoc {
                name: "scans",
                flag: Some("--scans"),
                help: "number of scans generated, N >= 2 (default: the scenario's); the \
                       harbour is built around their track, so they are not the first N of \
                       the default run",
            },
            OptionDoc {
                name: "seed",
                flag: Some("--scenario-seed"),
                help: "seed of the scenario (default: its own)",
            },
            OptionDoc {
                name: "dt_s",
                flag: Some("--dt"),
                help: "time between scans, s (default: the scenario's; not corridor, whose \
                       robot moves per scan)",
            },
            OptionDoc {
                name: "boats",
                flag: None,
                help: "rough only: the moving boats, a JSON file of them or none (default: the \
                       built-in three, configs/boats/harbour.json)",
            },
        ],
        open: open_synthetic,
    },
    Kind {
        name: "carmen",
        target: Target::Required("PATH"),
        summary: "a CARMEN FLASER log (.log or .log.gz)",
        options: &[
            OptionDoc {
                name: "fov_deg",
                flag: Some("--carmen-fov-deg"),
                help: "field of view of the laser, degrees (default 180)",
            },
            OptionDoc {
                name: "max_range_m",
                flag: Some("--carmen-max-range-m"),
                help: "readings at or beyond it are no-returns, m (default 50)",
            },
            OptionDoc {
                name: "reference_kind",
                flag: None,
                help: "what the logged poses are: slam_corrected (default) or odometry",
            },
            SCANS,
        ],
        open: open_carmen,
    },
    Kind {
        name: "csv",
        target: Target::Required("DIR"),
        summary: "our CSV format (scans.csv, poses.csv, dataset.json; written by `synth`)",
        options: &[
            OptionDoc {
                name: "dt_s",
                flag: Some("--dt"),
                help: "time between scans, s, for scans.csv without timestamps (refused when \
                       every scan has one: the time between two scans is then theirs)",
            },
            SCANS,
        ],
        open: open_csv,
    },
    Kind {
        name: "rosbag",
        target: Target::Required("PATH"),
        summary: "a ROS 2 bag: its directory (metadata.yaml) or one .mcap / .db3 file; \
                  LaserScan scans, reference from Odometry, PoseStamped, \
                  PoseWithCovarianceStamped or NavSatFix",
        options: &[
            OptionDoc {
                name: "scan",
                flag: None,
                help: "the LaserScan topic (default: the only one)",
            },
            OptionDoc {
                name: "reference",
                flag: None,
                help: "the reference topic, or none (default: the only one of a reference type)",
            },
            OptionDoc {
                name: "reference_kind",
                flag: None,
                help: "what the reference is: ground_truth, slam_corrected, odometry, unknown \
                       (default: odometry for Odometry, unknown for poses, gnss_positions for NavSatFix)",
            },
            OptionDoc {
                name: "body_frame",
                flag: None,
                help: "the frame whose pose the reference is (default: Odometry's child_frame_id, \
                       NavSatFix's frame_id, base_link for poses)",
            },
            OptionDoc {
                name: "tf",
                flag: None,
                help: "on: the scanner's offset from that frame from /tf_static, applied to \
                       rigid poses (default); off: the reference taken as the scanner's pose",
            },
            SCANS,
        ],
        open: open_rosbag,
    },
];

/// The help text of a `--dataset` option, generated from [`KINDS`].
pub fn help() -> String {
    let mut s = String::from("The dataset: KIND[:TARGET][?KEY=VALUE&...], one of:\n");
    for k in KINDS {
        s += &format!("  {}: {}\n", k.syntax(), k.summary);
        for o in k.options {
            let also = o.flag.map_or_else(String::new, |f| format!(" (also {f})"));
            s += &format!("      ?{}=: {}{also}\n", o.name, o.help);
        }
    }
    s
}

/// What flag `flag` sets, and in which kinds: `it sets ?seed= of synthetic datasets only: seed
/// of the scenario ...`.
fn flag_use(flag: &str) -> String {
    let users: Vec<(&str, &OptionDoc)> = KINDS
        .iter()
        .flat_map(|k| k.options.iter().map(move |o| (k.name, o)))
        .filter(|(_, o)| o.flag == Some(flag))
        .collect();
    let Some((_, first)) = users.first() else {
        return "no dataset kind has it".to_owned();
    };
    let kinds: Vec<&str> = users.iter().map(|(k, _)| *k).collect();
    let kinds = match kinds.split_last() {
        Some((last, [])) => (*last).to_owned(),
        Some((last, rest)) => format!("{} and {last}", rest.join(", ")),
        None => String::new(),
    };
    format!(
        "it sets ?{}= of {kinds} datasets only: {}",
        first.name, first.help
    )
}

/// The kinds' syntaxes, `marina | synthetic[:...] | ...`.
pub fn syntaxes() -> String {
    KINDS
        .iter()
        .map(Kind::syntax)
        .collect::<Vec<_>>()
        .join(" | ")
}

/// Why a dataset string does not name a loadable dataset.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SourceError {
    /// The kind is not registered.
    #[error("unknown dataset {kind:?}: expected {expected}")]
    UnknownKind {
        /// The kind given.
        kind: String,
        /// The registered kinds' syntaxes.
        expected: String,
    },
    /// A kind that needs a target was given none.
    #[error("dataset {kind}: missing the target, expected {syntax}")]
    MissingTarget {
        /// The kind.
        kind: &'static str,
        /// Its syntax.
        syntax: String,
    },
    /// A kind that takes no target was given one.
    #[error("dataset {kind} takes nothing after `:` (got {target:?})")]
    UnexpectedTarget {
        /// The kind.
        kind: &'static str,
        /// What was given.
        target: String,
    },
    /// An option the kind does not have, or one without `=`.
    #[error("dataset {kind}: unknown option {option:?}: expected one of {expected}")]
    UnknownOption {
        /// The kind.
        kind: &'static str,
        /// The option given.
        option: String,
        /// The kind's options.
        expected: String,
    },
    /// An option given twice (in the string, or in the string and by a flag, differently).
    #[error("dataset {kind}: option {option} given twice ({first:?} and {second:?})")]
    Repeated {
        /// The kind.
        kind: &'static str,
        /// The option.
        option: &'static str,
        /// The first value.
        first: String,
        /// The second value.
        second: String,
    },
    /// A command-line flag that sets an option other kinds have and this one does not.
    #[error("{flag} does not apply to a {kind} dataset: {why}")]
    FlagNotApplicable {
        /// The flag.
        flag: String,
        /// The kind.
        kind: &'static str,
        /// What the flag sets, and for which kinds.
        why: String,
    },
    /// An option the kind has that the loaded data leave nothing to do for.
    #[error("dataset {kind}: option {option}{} does not apply: {why}", flag.map_or_else(String::new, |f| format!(" ({f})")))]
    NotApplicable {
        /// The kind.
        kind: &'static str,
        /// The option.
        option: &'static str,
        /// The flag that also sets it.
        flag: Option<&'static str>,
        /// Why.
        why: String,
    },
    /// An option whose value is not usable.
    #[error("dataset {kind}: option {option} = {value:?}: {expected}")]
    BadValue {
        /// The kind.
        kind: &'static str,
        /// The option.
        option: &'static str,
        /// The value given.
        value: String,
        /// What it must be.
        expected: String,
    },
}

/// A parsed dataset string: a registered kind, its target and its options.
#[derive(Clone)]
pub struct DatasetSource {
    kind: &'static Kind,
    target: Option<String>,
    options: Vec<(&'static str, String)>,
}

impl fmt::Debug for DatasetSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("DatasetSource")
            .field("kind", &self.kind.name)
            .field("target", &self.target)
            .field("options", &self.options)
            .finish()
    }
}

impl FromStr for DatasetSource {
    type Err = SourceError;

    fn from_str(text: &str) -> Result<Self, SourceError> {
        let (head, query) = text.split_once('?').unwrap_or((text, ""));
        let (name, target) = match head.split_once(':') {
            Some((n, t)) => (n, Some(t.to_owned())),
            None => (head, None),
        };
        let kind =
            KINDS
                .iter()
                .find(|k| k.name == name)
                .ok_or_else(|| SourceError::UnknownKind {
                    kind: name.to_owned(),
                    expected: syntaxes(),
                })?;
        let target = target.filter(|t| !t.is_empty());
        match (kind.target, &target) {
            (Target::Required(_), None) => {
                return Err(SourceError::MissingTarget {
                    kind: kind.name,
                    syntax: kind.syntax(),
                })
            }
            (Target::None, Some(t)) => {
                return Err(SourceError::UnexpectedTarget {
                    kind: kind.name,
                    target: t.clone(),
                })
            }
            _ => {}
        }
        let mut source = Self {
            kind,
            target,
            options: Vec::new(),
        };
        for pair in query.split('&').filter(|p| !p.is_empty()) {
            let (key, value) = pair.split_once('=').unwrap_or((pair, ""));
            let option = source.option_name(key)?;
            if let Some((_, first)) = source.options.iter().find(|(k, _)| *k == option) {
                return Err(SourceError::Repeated {
                    kind: kind.name,
                    option,
                    first: first.clone(),
                    second: value.to_owned(),
                });
            }
            source.options.push((option, value.to_owned()));
        }
        Ok(source)
    }
}

impl DatasetSource {
    /// The kind.
    pub fn kind(&self) -> &'static Kind {
        self.kind
    }

    /// The registered name of option `key`, or the error naming it.
    fn option_name(&self, key: &str) -> Result<&'static str, SourceError> {
        self.kind
            .options
            .iter()
            .find(|o| o.name == key)
            .map(|o| o.name)
            .ok_or_else(|| SourceError::UnknownOption {
                kind: self.kind.name,
                option: key.to_owned(),
                expected: self
                    .kind
                    .options
                    .iter()
                    .map(|o| o.name)
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }

    /// Sets the option that command-line flag `flag` (`--dt`, `--scans`, ...: [`OptionDoc::flag`])
    /// stands for; refused when the kind has no such option (naming the kinds that have it)
    /// or when the string gave it a different value.
    pub fn set_from_flag(
        &mut self,
        flag: &str,
        value: impl fmt::Display,
    ) -> Result<(), SourceError> {
        let Some(option) = self
            .kind
            .options
            .iter()
            .find(|o| o.flag == Some(flag))
            .map(|o| o.name)
        else {
            return Err(SourceError::FlagNotApplicable {
                flag: flag.to_owned(),
                kind: self.kind.name,
                why: flag_use(flag),
            });
        };
        let value = value.to_string();
        let same = |a: &str, b: &str| {
            a == b || matches!((a.parse::<f64>(), b.parse::<f64>()), (Ok(x), Ok(y)) if x == y)
        };
        match self.options.iter().find(|(k, _)| *k == option) {
            Some((_, first)) if !same(first, &value) => Err(SourceError::Repeated {
                kind: self.kind.name,
                option,
                first: first.clone(),
                second: value,
            }),
            Some(_) => Ok(()),
            None => {
                self.options.push((option, value));
                Ok(())
            }
        }
    }

    /// The raw value of option `key`.
    fn raw(&self, key: &str) -> Option<&str> {
        self.options
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, v)| v.as_str())
    }

    /// Option `key` parsed, `expected` saying what it must be when it does not parse.
    fn get<T: FromStr>(&self, key: &'static str, expected: &str) -> Result<Option<T>, SourceError> {
        self.raw(key)
            .map(|v| {
                v.parse().map_err(|_| SourceError::BadValue {
                    kind: self.kind.name,
                    option: key,
                    value: v.to_owned(),
                    expected: expected.to_owned(),
                })
            })
            .transpose()
    }

    /// `dt_s`, which must be finite and positive.
    fn dt_s(&self) -> Result<Option<f64>, SourceError> {
        let dt = self.get::<f64>("dt_s", "a time in seconds")?;
        match dt {
            Some(d) if !(d.is_finite() && d > 0.0) => Err(SourceError::BadValue {
                kind: self.kind.name,
                option: "dt_s",
                value: d.to_string(),
                expected: "must be finite and positive".into(),
            }),
            _ => Ok(dt),
        }
    }

    /// `reference_kind`, one of `allowed`.
    fn reference_kind(
        &self,
        allowed: &[ReferenceKind],
    ) -> Result<Option<ReferenceKind>, SourceError> {
        let names = |ks: &[ReferenceKind]| {
            ks.iter()
                .map(|k| {
                    serde_json::to_value(k).map_or_else(
                        |_| String::new(),
                        |v| v.as_str().unwrap_or_default().to_owned(),
                    )
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        self.raw("reference_kind")
            .map(|v| {
                serde_json::from_value::<ReferenceKind>(serde_json::Value::String(v.to_owned()))
                    .ok()
                    .filter(|k| allowed.contains(k))
                    .ok_or_else(|| SourceError::BadValue {
                        kind: self.kind.name,
                        option: "reference_kind",
                        value: v.to_owned(),
                        expected: format!("expected one of {}", names(allowed)),
                    })
            })
            .transpose()
    }

    /// `scans`, which must leave a pair: at least 2.
    fn scans(&self) -> Result<Option<usize>, SourceError> {
        let n = self.get::<usize>("scans", "a count of scans")?;
        match n {
            Some(n) if n < 2 => Err(SourceError::BadValue {
                kind: self.kind.name,
                option: "scans",
                value: n.to_string(),
                expected: "at least 2: a run registers pairs of consecutive scans".into(),
            }),
            _ => Ok(n),
        }
    }

    /// The flag that also sets option `key`.
    fn flag_of(&self, key: &str) -> Option<&'static str> {
        self.kind
            .options
            .iter()
            .find(|o| o.name == key)
            .and_then(|o| o.flag)
    }

    /// The target as a path.
    fn path(&self) -> &Path {
        Path::new(self.target.as_deref().unwrap_or_default())
    }

    /// Loads the dataset (a `scans` that leaves no pair refused before anything is read).
    pub fn open(&self) -> Result<Dataset, DatasetError> {
        self.scans()?;
        (self.kind.open)(self)
    }
}

/// Parses and loads `text` (`kind[:target][?key=value&...]`).
pub fn open(text: &str) -> Result<Dataset, DatasetError> {
    text.parse::<DatasetSource>()?.open()
}

/// `dt_s` set on a loaded dataset (it replaces an assumed spacing); refused when every scan
/// has a timestamp, as the time between two scans is then the difference of theirs and the
/// spacing would change nothing but its display.
fn with_dt(mut ds: Dataset, s: &DatasetSource) -> Result<Dataset, DatasetError> {
    if let Some(dt) = s.dt_s()? {
        if ds.scans.iter().all(|scan| scan.timestamp_s().is_some()) {
            return Err(SourceError::NotApplicable {
                kind: s.kind.name,
                option: "dt_s",
                flag: s.flag_of("dt_s"),
                why: format!(
                    "every scan of {} has a timestamp, and the time between two scans is the \
                     difference of theirs",
                    ds.provenance.name
                ),
            }
            .into());
        }
        ds.set_dt_s(dt)?;
    }
    Ok(ds)
}

/// The first `scans` scans of a loaded dataset, when the option is given.
fn with_first_scans(ds: Dataset, s: &DatasetSource) -> Result<Dataset, DatasetError> {
    Ok(match s.scans()? {
        Some(n) => ds.keep_first(n),
        None => ds,
    })
}

fn open_marina(s: &DatasetSource) -> Result<Dataset, DatasetError> {
    let data_dir = s.raw("data_dir").map(PathBuf::from);
    let dir = marina::find_data_dir(data_dir.as_deref())?;
    let options = marina::MarinaOptions {
        dt_s: s.dt_s()?.unwrap_or(1.0),
        ..Default::default()
    };
    with_first_scans(marina::load(&dir, &options)?, s)
}

fn open_synthetic(s: &DatasetSource) -> Result<Dataset, DatasetError> {
    let name = s.target.as_deref().unwrap_or("paper");
    let (seed, n_scans) = (s.get("seed", "a non-negative integer")?, s.scans()?);
    if name == Corridor::NAME {
        return open_corridor(s, seed, n_scans);
    }
    let mut scenario = Scenario::by_name(name).ok_or_else(|| SourceError::BadValue {
        kind: "synthetic",
        option: "scenario",
        value: name.to_owned(),
        expected: format!("expected {}", Scenario::NAMES),
    })?;
    scenario.seed = seed.unwrap_or(scenario.seed);
    scenario.n_scans = n_scans.unwrap_or(scenario.n_scans);
    if let Some(dt) = s.dt_s()? {
        scenario.dt_s = dt;
    }
    synthetic::generate_with_boats(&scenario, s.raw("boats"))
}

/// The corridor scenario: `seed` and `scans` as for the harbour; `dt_s` and `boats` refused.
fn open_corridor(
    s: &DatasetSource,
    seed: Option<u64>,
    n_scans: Option<usize>,
) -> Result<Dataset, DatasetError> {
    if s.raw("dt_s").is_some() {
        return Err(SourceError::NotApplicable {
            kind: s.kind.name,
            option: "dt_s",
            flag: s.flag_of("dt_s"),
            why: Corridor::PLANNED_PER_SCAN.to_owned(),
        }
        .into());
    }
    let mut corridor = Corridor::default();
    corridor.seed = seed.unwrap_or(corridor.seed);
    corridor.n_scans = n_scans.unwrap_or(corridor.n_scans);
    synthetic::generate_corridor_without_boats(&corridor, s.raw("boats"))
}

fn open_carmen(s: &DatasetSource) -> Result<Dataset, DatasetError> {
    let defaults = CarmenOptions::default();
    let options = CarmenOptions {
        fov_deg: s
            .get("fov_deg", "an angle in degrees")?
            .unwrap_or(defaults.fov_deg),
        max_range_m: s
            .get("max_range_m", "a range in metres")?
            .unwrap_or(defaults.max_range_m),
        reference_kind: s
            .reference_kind(&[ReferenceKind::SlamCorrected, ReferenceKind::Odometry])?
            .unwrap_or(defaults.reference_kind),
        ..defaults
    };
    with_first_scans(carmen::load(s.path(), &options)?, s)
}

fn open_csv(s: &DatasetSource) -> Result<Dataset, DatasetError> {
    with_first_scans(with_dt(csvdir::load(s.path())?, s)?, s)
}

fn open_rosbag(s: &DatasetSource) -> Result<Dataset, DatasetError> {
    let options = RosbagOptions {
        scan_topic: s.raw("scan").map(str::to_owned),
        reference: match s.raw("reference") {
            None => ReferenceChoice::Auto,
            Some("none") => ReferenceChoice::Off,
            Some(t) => ReferenceChoice::Topic(t.to_owned()),
        },
        reference_kind: s.reference_kind(&[
            ReferenceKind::GroundTruth,
            ReferenceKind::SlamCorrected,
            ReferenceKind::Odometry,
            ReferenceKind::GnssPositions,
            ReferenceKind::Unknown,
        ])?,
        body_frame: s.raw("body_frame").map(str::to_owned),
        tf: match s.raw("tf") {
            None | Some("on") => true,
            Some("off") => false,
            Some(v) => {
                return Err(SourceError::BadValue {
                    kind: "rosbag",
                    option: "tf",
                    value: v.to_owned(),
                    expected: "expected on or off".into(),
                }
                .into())
            }
        },
    };
    with_first_scans(rosbag::load(s.path(), &options)?, s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_kinds_targets_and_options_and_names_what_is_wrong() {
        let s: DatasetSource = "carmen:a.log?fov_deg=270&max_range_m=30".parse().unwrap();
        assert_eq!(s.kind().name, "carmen");
        assert_eq!(s.path(), Path::new("a.log"));
        assert_eq!(s.get::<f64>("fov_deg", "").unwrap(), Some(270.0));
        let err = |t: &str| t.parse::<DatasetSource>().unwrap_err().to_string();
        assert_eq!(
            err("nowhere"),
            format!("unknown dataset \"nowhere\": expected {}", syntaxes())
        );
        assert_eq!(
            err("csv"),
            "dataset csv: missing the target, expected csv:DIR"
        );
        assert_eq!(
            err("marina:x"),
            "dataset marina takes nothing after `:` (got \"x\")"
        );
        assert_eq!(
            err("rosbag:b?topic=/scan"),
            "dataset rosbag: unknown option \"topic\": expected one of scan, reference, \
             reference_kind, body_frame, tf, scans"
        );
        assert_eq!(
            err("rosbag:b?scan=/a&scan=/b"),
            "dataset rosbag: option scan given twice (\"/a\" and \"/b\")"
        );
        let bad = "carmen:a.log?fov_deg=wide"
            .parse::<DatasetSource>()
            .unwrap();
        assert_eq!(
            bad.get::<f64>("fov_deg", "an angle in degrees")
                .unwrap_err()
                .to_string(),
            "dataset carmen: option fov_deg = \"wide\": an angle in degrees"
        );
        let kind = "carmen:a.log?reference_kind=ground_truth"
            .parse::<DatasetSource>()
            .unwrap();
        assert_eq!(
            kind.reference_kind(&[ReferenceKind::SlamCorrected, ReferenceKind::Odometry])
                .unwrap_err()
                .to_string(),
            "dataset carmen: option reference_kind = \"ground_truth\": expected one of \
             slam_corrected, odometry"
        );
    }

    #[test]
    fn flags_fill_options_the_string_left_out_and_clash_with_different_ones() {
        let mut s: DatasetSource = "carmen:a.log?fov_deg=270".parse().unwrap();
        s.set_from_flag("--carmen-max-range-m", 30.0).unwrap();
        s.set_from_flag("--carmen-fov-deg", 270.0).unwrap();
        s.set_from_flag("--carmen-fov-deg", "270.0").unwrap();
        s.set_from_flag("--scans", 5).unwrap();
        assert_eq!(s.raw("max_range_m"), Some("30"));
        assert_eq!(s.raw("scans"), Some("5"));
        assert!(matches!(
            s.set_from_flag("--carmen-fov-deg", 180.0),
            Err(SourceError::Repeated {
                option: "fov_deg",
                ..
            })
        ));
    }

    #[test]
    fn a_flag_of_another_kind_is_refused_naming_the_kinds_it_is_for() {
        let refusal = |dataset: &str, flag: &str| {
            let mut s: DatasetSource = dataset.parse().unwrap();
            s.set_from_flag(flag, 1).unwrap_err().to_string()
        };
        assert_eq!(
            refusal("carmen:a.log", "--scenario-seed"),
            "--scenario-seed does not apply to a carmen dataset: it sets ?seed= of synthetic \
             datasets only: seed of the scenario (default: its own)"
        );
        assert_eq!(
            refusal("csv:d", "--carmen-fov-deg"),
            "--carmen-fov-deg does not apply to a csv dataset: it sets ?fov_deg= of carmen \
             datasets only: field of view of the laser, degrees (default 180)"
        );
        assert_eq!(
            refusal("rosbag:b.mcap", "--dt"),
            format!(
                "--dt does not apply to a rosbag dataset: it sets ?dt_s= of marina, synthetic \
                 and csv datasets only: {}",
                KINDS[0].options[1].help
            )
        );
        assert!(refusal("synthetic", "--data-dir").starts_with(
            "--data-dir does not apply to a synthetic dataset: it sets ?data_dir= of marina"
        ));
    }

    #[test]
    fn scans_must_leave_a_pair() {
        for (text, value) in [("csv:d?scans=1", "1"), ("synthetic?scans=0", "0")] {
            let s: DatasetSource = text.parse().unwrap();
            let kind = s.kind().name;
            assert_eq!(
                s.scans().unwrap_err().to_string(),
                format!(
                    "dataset {kind}: option scans = \"{value}\": at least 2: a run registers \
                     pairs of consecutive scans"
                )
            );
        }
    }

    #[test]
    fn help_lists_every_kind_and_option() {
        let h = help();
        for k in KINDS {
            assert!(h.contains(&k.syntax()), "{h}");
            for o in k.options {
                assert!(h.contains(&format!("?{}=", o.name)), "{h}");
            }
        }
    }
}
