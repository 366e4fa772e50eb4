//! Our own plain-text format, so anyone can bring their data (see `datasets/README.md`): a
//! directory with `scans.csv` (one row per reading, optionally with the true surface normal
//! behind it and whether it came from a moving object), optionally `poses.csv` (one reference pose per scan), `odometry.csv` (one
//! odometry pose per scan: `scan,x_m,y_m,yaw_rad`, a rigid pose in the odometry's own frame,
//! yaw from `+x` towards `+y`) and `dataset.json` (name, timing, senses, sensor model, what the
//! reference is, the scanner's offset).
//!
//! Numbers are written in Rust's shortest round-trip form, so a dataset written and read back
//! is the same bit for bit.

use std::fmt::Write as _;
use std::io::Read;
use std::path::{Path, PathBuf};

use icp_core::scan::is_no_return;
use icp_core::{BearingSense, ReadingTruth, Scan, SensorModel};
use nalgebra::Vector2;
use serde::{Deserialize, Serialize};

use crate::dataset::{
    nominal_dt_s, Dataset, FileProvenance, Pose2, Provenance, ReferenceKind, ReferencePose,
};
use crate::{DatasetError, LoadWarning};

mod moving;
use moving::MovingCell;

/// Readings, one row each: `scan,timestamp_s,range_m,bearing_rad`, optionally followed by
/// `true_normal_x,true_normal_y` (the true surface normal behind the return, unitless, scan
/// frame; both cells empty when unknown; the two come together or not at all) and by `moving`
/// (1: the return came from a moving object, 0: it did not; empty on a no-return).
pub const SCANS_FILE: &str = "scans.csv";

/// The columns every `scans.csv` has.
const SCAN_COLUMNS: [&str; 4] = ["scan", "timestamp_s", "range_m", "bearing_rad"];
/// The optional true-normal columns of `scans.csv`.
const NORMAL_COLUMNS: [&str; 2] = ["true_normal_x", "true_normal_y"];
/// Reference poses, one row per scan: `scan,x_m,y_m,heading_rad,scan_yaw_rad`.
pub const POSES_FILE: &str = "poses.csv";
/// Odometry poses, one row per scan: `scan,x_m,y_m,yaw_rad` (metres; radians from `+x`
/// towards `+y`), in the odometry's own frame.
pub const ODOMETRY_FILE: &str = "odometry.csv";
/// Metadata.
pub const META_FILE: &str = "dataset.json";

/// The contents of `dataset.json`. Every field is optional.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatasetMeta {
    /// Short name (default: `csv:<directory name>`).
    pub name: Option<String>,
    /// Description.
    pub description: Option<String>,
    /// Nominal time between scans, s (default: the median timestamp step, else 1).
    pub dt_s: Option<f64>,
    /// Sense of the scanner's bearings (default counter-clockwise).
    pub bearing_sense: Option<BearingSense>,
    /// Sense of the reference heading (default counter-clockwise).
    pub reference_heading_sense: Option<BearingSense>,
    /// Sensor error model (default: the Sweep model).
    pub sensor: Option<SensorModel>,
    /// What `poses.csv` is (default, when there are poses: [`ReferenceKind::Unknown`], which
    /// also reads files written before the field existed). Refused without `poses.csv`.
    #[serde(default)]
    pub reference_kind: Option<ReferenceKind>,
    /// The scanner's pose in the frame of the point whose positions `poses.csv` gives
    /// (default: unknown).
    #[serde(default)]
    pub scanner_offset: Option<Pose2>,
    /// Time from a scan's first return to its last, s (default: unknown; see
    /// [`Dataset::sweep_s`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep_s: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ReadingRow {
    scan: usize,
    timestamp_s: Option<f64>,
    range_m: Option<f64>,
    bearing_rad: Option<f64>,
    #[serde(default)]
    true_normal_x: Option<f64>,
    #[serde(default)]
    true_normal_y: Option<f64>,
    #[serde(default)]
    moving: MovingCell,
}

impl ReadingRow {
    /// The row's true normal: none when both cells are empty, else both finite and not both
    /// zero. The error says which field is wrong.
    fn true_normal(&self) -> Result<Option<Vector2<f64>>, String> {
        let [nx, ny] = NORMAL_COLUMNS;
        let (x, y) = match (self.true_normal_x, self.true_normal_y) {
            (None, None) => return Ok(None),
            (Some(x), Some(y)) => (x, y),
            (Some(_), None) => return Err(format!("{ny} is empty but {nx} is not")),
            (None, Some(_)) => return Err(format!("{nx} is empty but {ny} is not")),
        };
        for (field, value) in [(nx, x), (ny, y)] {
            if !value.is_finite() {
                return Err(format!("non-finite {field}: {value}"));
            }
        }
        if x == 0.0 && y == 0.0 {
            return Err(format!("zero-length true normal: {nx} and {ny} are both 0"));
        }
        Ok(Some(Vector2::new(x, y)))
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PoseRow {
    scan: usize,
    x_m: f64,
    y_m: f64,
    heading_rad: f64,
    scan_yaw_rad: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OdometryRow {
    scan: usize,
    x_m: f64,
    y_m: f64,
    yaw_rad: f64,
}

/// A row of a file with one row per scan.
trait PerScanRow: serde::de::DeserializeOwned {
    /// The file's columns.
    const COLUMNS: &'static [&'static str];
    /// What a row holds, for messages.
    const WHAT: &'static str;
    /// What the row converts to.
    type Value;
    /// The scan the row is for.
    fn scan(&self) -> usize;
    /// The row's value, if every number in it is finite.
    fn value(&self) -> Option<Self::Value>;
}

impl PerScanRow for PoseRow {
    const COLUMNS: &'static [&'static str] = &["scan", "x_m", "y_m", "heading_rad", "scan_yaw_rad"];
    const WHAT: &'static str = "pose";
    type Value = ReferencePose;
    fn scan(&self) -> usize {
        self.scan
    }
    fn value(&self) -> Option<ReferencePose> {
        [
            self.x_m,
            self.y_m,
            self.heading_rad,
            self.scan_yaw_rad.unwrap_or(0.0),
        ]
        .iter()
        .all(|v| v.is_finite())
        .then_some(ReferencePose {
            x_m: self.x_m,
            y_m: self.y_m,
            heading_rad: self.heading_rad,
            scan_yaw_rad: self.scan_yaw_rad,
        })
    }
}

impl PerScanRow for OdometryRow {
    const COLUMNS: &'static [&'static str] = &["scan", "x_m", "y_m", "yaw_rad"];
    const WHAT: &'static str = "odometry pose";
    type Value = Pose2;
    fn scan(&self) -> usize {
        self.scan
    }
    fn value(&self) -> Option<Pose2> {
        let pose = Pose2 {
            x_m: self.x_m,
            y_m: self.y_m,
            yaw_rad: self.yaw_rad,
        };
        [pose.x_m, pose.y_m, pose.yaw_rad]
            .iter()
            .all(|v| v.is_finite())
            .then_some(pose)
    }
}

/// The values of a file with one row per scan: rows `0, 1, 2, …`, one per each of the
/// `n_scans` scans read from `scans_path`, every number finite.
fn per_scan<T: PerScanRow, R: Read>(
    path: &Path,
    reader: R,
    (scans_path, n_scans): (&Path, usize),
) -> Result<Vec<T::Value>, DatasetError> {
    let mut out = Vec::with_capacity(n_scans);
    for (line, row) in rows::<T, _>(path, reader, T::COLUMNS, &[])? {
        let bad = |what: String| DatasetError::Parse {
            path: path.to_path_buf(),
            line,
            what,
        };
        if row.scan() != out.len() {
            return Err(bad(format!(
                "{} rows must run 0, 1, 2, …: expected scan {}, found {}",
                T::WHAT,
                out.len(),
                row.scan()
            )));
        }
        let value = row
            .value()
            .ok_or_else(|| bad(format!("non-finite {} for scan {}", T::WHAT, row.scan())))?;
        out.push(value);
    }
    if out.len() != n_scans {
        return Err(DatasetError::RowsPerScan {
            path: path.to_path_buf(),
            what: T::WHAT,
            rows: out.len(),
            scans_path: scans_path.to_path_buf(),
            scans: n_scans,
        });
    }
    Ok(out)
}

fn csv_error(path: &Path, e: &csv::Error) -> DatasetError {
    let line = e.position().map_or(0, |p| p.line() as usize);
    DatasetError::Parse {
        path: path.to_path_buf(),
        line,
        what: e.to_string(),
    }
}

/// Every row of a CSV file whose header has exactly `columns`, plus of each group of
/// `optional` either all or none, deserialized, with its line.
fn rows<T: serde::de::DeserializeOwned, R: Read>(
    path: &Path,
    reader: R,
    columns: &[&str],
    optional: &[&[&str]],
) -> Result<Vec<(usize, T)>, DatasetError> {
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(reader);
    let headers = rdr.headers().map_err(|e| csv_error(path, &e))?.clone();
    let header_error = |what: String| DatasetError::Parse {
        path: path.to_path_buf(),
        line: 1,
        what,
    };
    let expected = optional.iter().fold(columns.join(","), |e, group| {
        format!("{e}[,{}]", group.join(","))
    });
    let has = |c: &str| headers.iter().any(|h| h == c);
    if let Some(missing) = columns.iter().find(|c| !has(c)) {
        return Err(header_error(format!(
            "missing column {missing:?} (expected {expected})"
        )));
    }
    if let Some(extra) = headers
        .iter()
        .find(|h| !columns.contains(h) && !optional.iter().any(|g| g.contains(h)))
    {
        return Err(header_error(format!(
            "unknown column {extra:?} (expected {expected})"
        )));
    }
    for group in optional {
        if let (Some(present), Some(absent)) = (
            group.iter().find(|c| has(c)),
            group.iter().find(|c| !has(c)),
        ) {
            return Err(header_error(format!(
                "column {present:?} without {absent:?} (expected {expected})"
            )));
        }
    }
    let mut record = csv::StringRecord::new();
    let mut out = Vec::new();
    while rdr
        .read_record(&mut record)
        .map_err(|e| csv_error(path, &e))?
    {
        let line = record.position().map_or(0, |p| p.line() as usize);
        let row = record
            .deserialize(Some(&headers))
            .map_err(|e| DatasetError::Parse {
                path: path.to_path_buf(),
                line,
                what: e.to_string(),
            })?;
        out.push((line, row));
    }
    Ok(out)
}

fn read_file(path: &Path) -> Result<Vec<u8>, DatasetError> {
    std::fs::read(path).map_err(|source| DatasetError::Io {
        path: path.to_path_buf(),
        source,
    })
}

fn provenance_of(path: PathBuf, bytes: &[u8]) -> FileProvenance {
    FileProvenance::of(path, bytes)
}

/// Loads a dataset directory.
pub fn load(dir: &Path) -> Result<Dataset, DatasetError> {
    let scans_path = dir.join(SCANS_FILE);
    let scans_bytes = read_file(&scans_path)?;
    let mut files = vec![provenance_of(scans_path.clone(), &scans_bytes)];
    let mut optional = |name: &str| -> Result<(PathBuf, Option<Vec<u8>>), DatasetError> {
        let path = dir.join(name);
        if !path.is_file() {
            return Ok((path, None));
        }
        let bytes = read_file(&path)?;
        files.push(provenance_of(path.clone(), &bytes));
        Ok((path, Some(bytes)))
    };
    let (poses_path, poses_bytes) = optional(POSES_FILE)?;
    let (odometry_path, odometry_bytes) = optional(ODOMETRY_FILE)?;
    let meta_path = dir.join(META_FILE);
    let meta = if meta_path.is_file() {
        let bytes = read_file(&meta_path)?;
        files.push(provenance_of(meta_path.clone(), &bytes));
        serde_json::from_slice(&bytes).map_err(|e| DatasetError::Parse {
            path: meta_path.clone(),
            line: e.line(),
            what: e.to_string(),
        })?
    } else {
        DatasetMeta::default()
    };
    let default_name = format!(
        "csv:{}",
        dir.file_name().map_or_else(
            || dir.display().to_string(),
            |n| n.to_string_lossy().into_owned()
        )
    );
    let mut ds = parse(
        (&scans_path, &scans_bytes[..]),
        poses_bytes.as_deref().map(|b| (poses_path.as_path(), b)),
        odometry_bytes
            .as_deref()
            .map(|b| (odometry_path.as_path(), b)),
        &meta,
        &default_name,
    )?;
    ds.provenance.files = files;
    Ok(ds)
}

/// Parses the readings and (optionally) the reference and odometry poses; the paths name them
/// in errors.
pub fn parse<R: Read>(
    scans: (&Path, R),
    poses: Option<(&Path, R)>,
    odometry: Option<(&Path, R)>,
    meta: &DatasetMeta,
    default_name: &str,
) -> Result<Dataset, DatasetError> {
    let (scans_path, reader) = scans;
    let mut out: Vec<Scan> = Vec::new();
    let (mut ranges, mut bearings, mut normals) = (Vec::new(), Vec::new(), Vec::new());
    // Each reading's moving label, when the file has the column.
    let (mut moving, mut labelled) = (Vec::new(), false);
    let mut current: Option<(usize, Option<f64>)> = None;
    let finish = |id: usize,
                  ts: Option<f64>,
                  ranges: &[f64],
                  bearings: &[f64],
                  normals: &[Option<Vector2<f64>>],
                  moving: Option<&[bool]>|
     -> Result<Scan, DatasetError> {
        let truth = ReadingTruth {
            true_normals: Some(normals),
            moving,
        };
        let scan = Scan::from_polar_with_truth(ranges, bearings, truth).map_err(|source| {
            DatasetError::Scan {
                path: scans_path.to_path_buf(),
                scan: id,
                source,
            }
        })?;
        match ts {
            Some(t) => scan.with_timestamp(t).map_err(|source| DatasetError::Scan {
                path: scans_path.to_path_buf(),
                scan: id,
                source,
            }),
            None => Ok(scan),
        }
    };
    let optional: [&[&str]; 2] = [&NORMAL_COLUMNS, &[moving::COLUMN]];
    for (line, row) in rows::<ReadingRow, _>(scans_path, reader, &SCAN_COLUMNS, &optional)? {
        let bad = |what: String| DatasetError::Parse {
            path: scans_path.to_path_buf(),
            line,
            what,
        };
        match current {
            Some((id, ts)) if id == row.scan => {
                if ts != row.timestamp_s
                    && !(ts.is_some_and(f64::is_nan) && row.timestamp_s.is_some_and(f64::is_nan))
                {
                    return Err(bad(format!(
                        "scan {id} has two timestamps: {ts:?} and {:?}",
                        row.timestamp_s
                    )));
                }
            }
            Some((id, ts)) => {
                if row.scan != id + 1 {
                    return Err(bad(format!(
                        "scan ids must increase by one: scan {} follows scan {id}",
                        row.scan
                    )));
                }
                let labels = labelled.then_some(&moving[..]);
                out.push(finish(id, ts, &ranges, &bearings, &normals, labels)?);
                ranges.clear();
                bearings.clear();
                normals.clear();
                moving.clear();
                current = Some((row.scan, row.timestamp_s));
            }
            None => {
                if row.scan != 0 {
                    return Err(bad(format!(
                        "the first scan id must be 0, not {}",
                        row.scan
                    )));
                }
                current = Some((0, row.timestamp_s));
            }
        }
        let range_m = row.range_m.unwrap_or(f64::NAN);
        let label = row.moving.label(is_no_return(range_m)).map_err(bad)?;
        labelled = label.is_some();
        moving.push(label.unwrap_or(false));
        ranges.push(range_m);
        bearings.push(row.bearing_rad.unwrap_or(f64::NAN));
        normals.push(row.true_normal().map_err(bad)?);
    }
    if let Some((id, ts)) = current {
        let labels = labelled.then_some(&moving[..]);
        out.push(finish(id, ts, &ranges, &bearings, &normals, labels)?);
    }
    let scans = (scans_path, out.len());
    let reference = poses
        .map(|(path, reader)| per_scan::<PoseRow, _>(path, reader, scans))
        .transpose()?;
    let odometry = odometry
        .map(|(path, reader)| per_scan::<OdometryRow, _>(path, reader, scans))
        .transpose()?;
    let reference_kind = match (&reference, meta.reference_kind) {
        (Some(_), kind) => Some(kind.unwrap_or(ReferenceKind::Unknown)),
        (None, None) => None,
        (None, Some(kind)) => {
            return Err(DatasetError::BadValue {
                path: META_FILE.into(),
                what: format!(
                    "reference_kind is {} but there is no {POSES_FILE}",
                    serde_json::to_string(&kind).unwrap_or_default()
                ),
            })
        }
    };
    if let Some(offset) = meta.scanner_offset {
        if [offset.x_m, offset.y_m, offset.yaw_rad]
            .iter()
            .any(|v| !v.is_finite())
        {
            return Err(DatasetError::BadValue {
                path: META_FILE.into(),
                what: format!("non-finite scanner_offset: {offset:?}"),
            });
        }
    }
    if let Some(sweep_s) = meta.sweep_s.filter(|s| !(s.is_finite() && *s >= 0.0)) {
        return Err(DatasetError::BadValue {
            path: META_FILE.into(),
            what: format!("sweep_s {sweep_s}: not a finite, non-negative number of seconds"),
        });
    }
    let sensor = meta.sensor.unwrap_or_default();
    sensor.validate().map_err(|e| DatasetError::BadValue {
        path: META_FILE.into(),
        what: e.to_string(),
    })?;
    let (dt_s, assumed) = nominal_dt_s(&out);
    let name = meta.name.clone().unwrap_or_else(|| default_name.to_owned());
    let mut ds = Dataset {
        provenance: Provenance {
            description: meta
                .description
                .clone()
                .unwrap_or_else(|| format!("{name}: {} scans from our CSV format", out.len())),
            name,
            files: Vec::new(),
        },
        scans: out,
        reference,
        reference_kind,
        odometry,
        scanner_offset: meta.scanner_offset,
        reference_heading_sense: meta
            .reference_heading_sense
            .unwrap_or(BearingSense::CounterClockwise),
        dt_s,
        sensor,
        sweep_s: meta.sweep_s,
        bearing_sense: meta.bearing_sense.unwrap_or(BearingSense::CounterClockwise),
        warnings: assumed
            .into_iter()
            .chain(
                meta.sensor
                    .is_none()
                    .then(|| LoadWarning::AssumedSensorModel {
                        sensor,
                        of: "the Scanse Sweep (the paper's scanner)".to_owned(),
                    }),
            )
            .collect(),
        first_scans: None,
    };
    if let Some(dt) = meta.dt_s {
        ds.set_dt_s(dt)?;
    }
    Ok(ds.checked())
}

/// Writes `ds` as a dataset directory (creating it): `scans.csv`, `dataset.json`, and
/// `poses.csv` and `odometry.csv` when it has those channels. Each scan's no-returns are
/// written as rows with empty range and bearing, so the counts survive the round trip. The true-normal
/// columns are written when any scan carries true normals, empty where a normal is unknown; the
/// `moving` column when every scan with returns carries moving labels (empty on no-returns).
pub fn write(dir: &Path, ds: &Dataset) -> Result<(), DatasetError> {
    std::fs::create_dir_all(dir).map_err(|source| DatasetError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let opt = |v: Option<f64>| v.map_or_else(String::new, |v| v.to_string());
    let with_normals = ds.scans.iter().any(|s| s.true_normals().is_some());
    let with_moving = ds.scans.iter().any(|s| s.moving().is_some())
        && ds
            .scans
            .iter()
            .all(|s| s.is_empty() || s.moving().is_some());
    let mut s = SCAN_COLUMNS.join(",");
    if with_normals {
        let _ = write!(s, ",{}", NORMAL_COLUMNS.join(","));
    }
    if with_moving {
        let _ = write!(s, ",{}", moving::COLUMN);
    }
    s.push('\n');
    for (k, scan) in ds.scans.iter().enumerate() {
        let ts = opt(scan.timestamp_s());
        let normals = scan.true_normals();
        let moving = scan.moving().filter(|_| with_moving);
        for (i, r) in scan.returns().iter().enumerate() {
            let _ = write!(s, "{k},{ts},{},{}", r.range_m, r.bearing_rad);
            if with_normals {
                match normals.and_then(|n| n.get(i).copied().flatten()) {
                    Some(n) => {
                        let _ = write!(s, ",{},{}", n.x, n.y);
                    }
                    None => s.push_str(",,"),
                }
            }
            if let Some(moving) = moving {
                let _ = write!(s, ",{}", u8::from(moving[i]));
            }
            s.push('\n');
        }
        for _ in 0..scan.no_returns() {
            let _ = write!(s, "{k},{ts},,");
            if with_normals {
                s.push_str(",,");
            }
            if with_moving {
                s.push(',');
            }
            s.push('\n');
        }
    }
    write_file(&dir.join(SCANS_FILE), s.as_bytes())?;
    if let Some(poses) = &ds.reference {
        let mut s = format!("{}\n", PoseRow::COLUMNS.join(","));
        for (k, p) in poses.iter().enumerate() {
            let _ = writeln!(
                s,
                "{k},{},{},{},{}",
                p.x_m,
                p.y_m,
                p.heading_rad,
                opt(p.scan_yaw_rad)
            );
        }
        write_file(&dir.join(POSES_FILE), s.as_bytes())?;
    }
    if let Some(poses) = &ds.odometry {
        let mut s = format!("{}\n", OdometryRow::COLUMNS.join(","));
        for (k, p) in poses.iter().enumerate() {
            let _ = writeln!(s, "{k},{},{},{}", p.x_m, p.y_m, p.yaw_rad);
        }
        write_file(&dir.join(ODOMETRY_FILE), s.as_bytes())?;
    }
    let meta = DatasetMeta {
        name: Some(ds.provenance.name.clone()),
        description: Some(ds.provenance.description.clone()),
        dt_s: Some(ds.dt_s),
        bearing_sense: Some(ds.bearing_sense),
        reference_heading_sense: Some(ds.reference_heading_sense),
        sensor: Some(ds.sensor),
        reference_kind: ds.reference_kind,
        scanner_offset: ds.scanner_offset,
        sweep_s: ds.sweep_s,
    };
    let json = serde_json::to_string_pretty(&meta).map_err(|e| DatasetError::BadValue {
        path: dir.join(META_FILE),
        what: e.to_string(),
    })?;
    write_file(&dir.join(META_FILE), (json + "\n").as_bytes())
}

/// Writes through a temporary file and a rename, so a reader never sees half a file.
fn write_file(path: &Path, bytes: &[u8]) -> Result<(), DatasetError> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, bytes).map_err(|source| DatasetError::Io {
        path: tmp.clone(),
        source,
    })?;
    std::fs::rename(&tmp, path).map_err(|source| DatasetError::Io {
        path: path.to_path_buf(),
        source,
    })
}
