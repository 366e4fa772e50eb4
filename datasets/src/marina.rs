//! The paper's public data: three MATLAB v5 files from the authors' repository
//! `lukisp2/ICP_DATA_MARINA` (Naus & Marchel 2019).
//!
//! - `angles.mat`: `angles_baza`, 750 × 177, bearings in radians, column = scan;
//! - `ranges.mat`: `ranges_baza`, 750 × 177, ranges in metres (NaN or 0 = no return);
//! - `gps.mat`: `slam_pose`, 177 × 3: x, y (metres, local frame) and heading (radians).
//!
//! The reference is [`ReferenceKind::GnssPositions`]: despite its name, `slam_pose` holds the
//! GNSS RTK positions and a heading, which are not one rigid frame (the positions advance
//! along +x whatever the heading). The files have no odometry, and name no offset between the
//! GNSS antenna and the scanner, so [`Dataset::scanner_offset`] is unknown.
//!
//! The files carry no timestamps: consecutive reference positions are about 1.24 m apart at
//! about 1.2 m/s, so the nominal spacing is 1.0 s ([`MarinaOptions::dt_s`]).

use std::borrow::Cow;
use std::io::Read;
use std::path::{Path, PathBuf};

use icp_core::{BearingSense, Scan, SensorModel};
use sha2::{Digest, Sha256};

use crate::dataset::{Dataset, FileProvenance, Provenance, ReferenceKind, ReferencePose};
use crate::DatasetError;

/// The three files and the variables they hold.
pub const FILES: [(&str, &str); 3] = [
    ("angles.mat", "angles_baza"),
    ("ranges.mat", "ranges_baza"),
    ("gps.mat", "slam_pose"),
];

/// The pinned SHA-256 sums, in `sha256sum` format: the same file `scripts/fetch-marina.sh`
/// checks downloads against.
pub const PINNED_SHA256: &str = include_str!("../marina.sha256");

/// The pinned SHA-256 of one of [`FILES`], if any.
pub fn pinned_sha256(file: &str) -> Option<&'static str> {
    PINNED_SHA256.lines().find_map(|line| {
        let (sum, name) = line.split_once(char::is_whitespace)?;
        (name.trim().trim_start_matches('*') == file).then_some(sum)
    })
}

/// Environment variable naming the data directory.
pub const DATA_DIR_ENV: &str = "ICP_DATA_DIR";

/// How to get the files, for error messages.
pub const FETCH_HINT: &str =
    "Fetch them with `scripts/fetch-marina.sh [DIR]` (checked against pinned sha256 sums), \
then pass `--data-dir DIR` or set ICP_DATA_DIR=DIR.";

/// Loader parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarinaOptions {
    /// Time between consecutive scans, seconds: the files have no timestamps (1.0 nominal).
    pub dt_s: f64,
    /// The sensor model (Scanse Sweep by default).
    pub sensor: SensorModel,
}

impl Default for MarinaOptions {
    fn default() -> Self {
        Self {
            dt_s: 1.0,
            sensor: SensorModel::sweep(),
        }
    }
}

/// The directories searched for the marina files, in order: `--data-dir` alone when it is
/// given (an explicit choice is never silently replaced by another directory); otherwise
/// `$ICP_DATA_DIR`, then `./datasets`. Each either holds the files or a `marina/` folder
/// holding them.
pub fn candidate_dirs(cli_dir: Option<&Path>, env_dir: Option<&Path>) -> Vec<PathBuf> {
    let roots: Vec<PathBuf> = match (cli_dir, env_dir) {
        (Some(d), _) => vec![d.to_path_buf()],
        (None, Some(e)) => vec![e.to_path_buf(), PathBuf::from("datasets")],
        (None, None) => vec![PathBuf::from("datasets")],
    };
    roots
        .into_iter()
        .flat_map(|r| [r.join("marina"), r])
        .collect()
}

/// Finds the directory holding the three files (see [`candidate_dirs`]; `ICP_DATA_DIR` is read
/// from the environment).
pub fn find_data_dir(cli_dir: Option<&Path>) -> Result<PathBuf, DatasetError> {
    let env_dir = std::env::var_os(DATA_DIR_ENV).map(PathBuf::from);
    find_in(candidate_dirs(cli_dir, env_dir.as_deref()))
}

/// The first of `looked` that holds the three files.
pub fn find_in(looked: Vec<PathBuf>) -> Result<PathBuf, DatasetError> {
    looked
        .iter()
        .find(|d| FILES.iter().all(|(f, _)| d.join(f).is_file()))
        .cloned()
        .ok_or_else(|| DatasetError::NotFound {
            dataset: "marina",
            looked,
            hint: format!("Expected angles.mat, ranges.mat and gps.mat. {FETCH_HINT}"),
        })
}

/// Loads the marina dataset from `dir` (the folder holding the three files).
pub fn load(dir: &Path, options: &MarinaOptions) -> Result<Dataset, DatasetError> {
    check_options(options)?;
    // Each file is read, hashed and decoded on its own thread: hashing and inflating 1.6 MB
    // are most of the load. Errors are reported in file order, reading errors first.
    let job = |name: &str, variable: &str| -> Result<_, DatasetError> {
        let path = dir.join(name);
        let data = std::fs::read(&path).map_err(|source| DatasetError::Io {
            path: path.clone(),
            source,
        })?;
        let sha256 = hex(&Sha256::digest(&data));
        let matrix = read_matrix(&path, &data[..], variable);
        let file = FileProvenance {
            matches_pinned: pinned_sha256(name).map(|p| p == sha256),
            path,
            sha256,
        };
        Ok((file, matrix))
    };
    let [angles, ranges, gps] =
        side_by_side(FILES.map(|(name, variable)| move || job(name, variable)));
    let [(angles_file, angles), (ranges_file, ranges), (gps_file, gps)] = [angles?, ranges?, gps?];
    let mut dataset = assemble(
        [&angles_file.path, &ranges_file.path, &gps_file.path],
        [angles?, ranges?, gps?],
        options,
    )?;
    dataset.provenance.files = vec![angles_file, ranges_file, gps_file];
    Ok(dataset)
}

/// Runs three jobs on their own threads and returns their results in order.
fn side_by_side<T: Send, F: FnOnce() -> T + Send>(jobs: [F; 3]) -> [T; 3] {
    std::thread::scope(|scope| {
        jobs.map(|job| scope.spawn(job)).map(|handle| {
            handle
                .join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
        })
    })
}

/// Parses the three files (angles, ranges, gps, in that order), each given with the path used
/// in error messages.
pub fn parse<R: Read>(
    inputs: [(&Path, R); 3],
    options: &MarinaOptions,
) -> Result<Dataset, DatasetError> {
    check_options(options)?;
    let paths = inputs.each_ref().map(|(path, _)| *path);
    let [(angles_path, angles), (ranges_path, ranges), (gps_path, gps)] = inputs;
    let angles = read_matrix(angles_path, angles, FILES[0].1)?;
    let ranges = read_matrix(ranges_path, ranges, FILES[1].1)?;
    let pose = read_matrix(gps_path, gps, FILES[2].1)?;
    assemble(paths, [angles, ranges, pose], options)
}

fn check_options(options: &MarinaOptions) -> Result<(), DatasetError> {
    if !(options.dt_s.is_finite() && options.dt_s > 0.0) {
        return Err(DatasetError::InvalidParameter {
            name: "dt_s",
            value: options.dt_s,
            reason: "must be finite and positive",
        });
    }
    DatasetError::check_sensor(&options.sensor)
}

/// The dataset from the three matrices (angles, ranges, poses) read from `paths`.
fn assemble(
    [_, ranges_path, gps_path]: [&Path; 3],
    [angles, ranges, pose]: [Matrix; 3],
    options: &MarinaOptions,
) -> Result<Dataset, DatasetError> {
    if angles.rows != ranges.rows || angles.cols != ranges.cols {
        return Err(DatasetError::Shape {
            path: ranges_path.to_path_buf(),
            name: FILES[1].1.into(),
            expected: format!("{} x {} like {}", angles.rows, angles.cols, FILES[0].1),
            got: vec![ranges.rows, ranges.cols],
        });
    }
    let n_scans = angles.cols;
    if pose.rows != n_scans || pose.cols != 3 {
        return Err(DatasetError::Shape {
            path: gps_path.to_path_buf(),
            name: FILES[2].1.into(),
            expected: format!("{n_scans} x 3 (one x, y, heading row per scan)"),
            got: vec![pose.rows, pose.cols],
        });
    }
    let mut scans = Vec::with_capacity(n_scans);
    for k in 0..n_scans {
        let scan = Scan::from_polar(ranges.column(k), angles.column(k)).map_err(|source| {
            DatasetError::Scan {
                path: ranges_path.to_path_buf(),
                scan: k,
                source,
            }
        })?;
        scans.push(
            scan.with_timestamp(k as f64 * options.dt_s)
                .map_err(|source| DatasetError::Scan {
                    path: ranges_path.to_path_buf(),
                    scan: k,
                    source,
                })?,
        );
    }
    let mut reference = Vec::with_capacity(n_scans);
    for k in 0..n_scans {
        let (x_m, y_m, heading_rad) = (pose.get(k, 0), pose.get(k, 1), pose.get(k, 2));
        if !(x_m.is_finite() && y_m.is_finite() && heading_rad.is_finite()) {
            return Err(DatasetError::BadValue {
                path: gps_path.to_path_buf(),
                what: format!(
                    "non-finite reference pose in row {k}: ({x_m}, {y_m}, {heading_rad})"
                ),
            });
        }
        // The positions advance along +x whatever the heading (it turns by 85° and back while
        // the track stays within 7° of +x), so they are not a rigid pose of the scanner.
        reference.push(ReferencePose {
            x_m,
            y_m,
            heading_rad,
            scan_yaw_rad: None,
        });
    }
    Ok(Dataset {
        provenance: Provenance {
            name: "marina".into(),
            description:
                "Naus & Marchel (2019), Appl. Sci. 9(17) 3530: Gdynia yacht basin, Scanse Sweep, \
                          GNSS RTK reference (public files from lukisp2/ICP_DATA_MARINA)"
                    .into(),
            files: Vec::new(),
        },
        scans,
        reference: Some(reference),
        reference_kind: Some(ReferenceKind::GnssPositions),
        odometry: None,
        scanner_offset: None,
        reference_heading_sense: REFERENCE_HEADING_SENSE,
        dt_s: options.dt_s,
        // The files do not say how fast the Sweep turned.
        sweep_s: None,
        sensor: options.sensor,
        bearing_sense: BEARING_SENSE,
        warnings: Vec::new(),
        first_scans: None,
    }
    .checked())
}

/// The sense of the scanner's bearings. The files only fix it *relative* to the reference
/// heading: over the 175 pairs the registered rotation and the `slam_pose` heading change are
/// anti-correlated (r ≈ −0.9, checked by a test), so bearings and heading grow in the same
/// sense. We take both as clockwise, the navigational sense of a heading in [0, 2π) (it starts
/// at 270°); were both counter-clockwise, every error statistic would be the same and only the
/// sign of the reported turns would flip.
pub const BEARING_SENSE: BearingSense = BearingSense::Clockwise;
/// `slam_pose` headings grow clockwise seen from above (see [`BEARING_SENSE`]).
pub const REFERENCE_HEADING_SENSE: BearingSense = BearingSense::Clockwise;

/// A real double matrix, column-major.
struct Matrix {
    rows: usize,
    cols: usize,
    data: Vec<f64>,
}

impl Matrix {
    fn column(&self, c: usize) -> &[f64] {
        &self.data[c * self.rows..(c + 1) * self.rows]
    }
    fn get(&self, r: usize, c: usize) -> f64 {
        self.data[c * self.rows + r]
    }
}

fn read_matrix<R: Read>(path: &Path, mut reader: R, name: &str) -> Result<Matrix, DatasetError> {
    let mut bytes = Vec::new();
    reader
        .read_to_end(&mut bytes)
        .map_err(|source| DatasetError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    let parse_error = |reason: String| DatasetError::MatParse {
        path: path.to_path_buf(),
        reason,
    };
    if bytes.len() < 128 {
        return Err(parse_error(format!(
            "{} bytes, shorter than the 128-byte MATLAB v5 header",
            bytes.len()
        )));
    }
    if !bytes.starts_with(b"MATLAB 5.0 MAT-file") {
        return Err(parse_error(
            "the header does not start with \"MATLAB 5.0 MAT-file\"".into(),
        ));
    }
    let bytes = inflate_elements(&bytes).map_err(parse_error)?;
    let file = matfile::MatFile::parse(&bytes[..]).map_err(|e| parse_error(e.to_string()))?;
    let array = file
        .find_by_name(name)
        .ok_or_else(|| DatasetError::MissingVariable {
            path: path.to_path_buf(),
            name: name.into(),
            found: file.arrays().iter().map(|a| a.name().to_owned()).collect(),
        })?;
    let size = array.size().clone();
    let data = match array.data() {
        matfile::NumericData::Double { real, imag: None } => real.clone(),
        _ => {
            return Err(DatasetError::NotRealDouble {
                path: path.to_path_buf(),
                name: name.into(),
            })
        }
    };
    if size.len() != 2 || size[0] * size[1] != data.len() {
        return Err(DatasetError::Shape {
            path: path.to_path_buf(),
            name: name.into(),
            expected: format!("a 2-D matrix holding its {} values", data.len()),
            got: size,
        });
    }
    Ok(Matrix {
        rows: size[0],
        cols: size[1],
        data,
    })
}

/// The data type of a compressed data element (its data: a zlib stream of one whole element).
const MI_COMPRESSED: u32 = 15;

/// Walks the top-level data elements after the 128-byte header, and returns the file with its
/// compressed elements inflated in place. Each element must fit in the file, so a truncated
/// download is named as such instead of losing its last variable silently (the MATLAB reader
/// skips an element it cannot complete). Inflating here rather than in the MATLAB reader
/// halves the load: its inflater takes 2.5 times as long as `flate2`'s on these files.
fn inflate_elements(bytes: &[u8]) -> Result<Cow<'_, [u8]>, String> {
    let word = |at: usize| -> u32 {
        let w = [bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]];
        if &bytes[126..128] == b"MI" {
            u32::from_be_bytes(w)
        } else {
            u32::from_le_bytes(w)
        }
    };
    let mut out: Option<Vec<u8>> = None;
    let mut at = 128;
    while bytes.len() - at >= 8 {
        let (kind, size) = if word(at) >> 16 != 0 {
            (word(at) & 0xffff, 0) // a small element: its data sits in its 8-byte tag
        } else {
            (word(at), word(at + 4) as usize)
        };
        let remain = bytes.len() - at - 8;
        if size > remain {
            return Err(format!(
                "truncated: the data element at byte {at} declares {size} bytes, {remain} remain"
            ));
        }
        let element = &bytes[at..at + 8 + size];
        if kind == MI_COMPRESSED {
            let out = out.get_or_insert_with(|| bytes[..at].to_vec());
            flate2::read::ZlibDecoder::new(&element[8..])
                .read_to_end(out)
                .map_err(|e| {
                    format!("the compressed data element at byte {at} does not inflate: {e}")
                })?;
        } else if let Some(out) = &mut out {
            out.extend_from_slice(element);
        }
        at += 8 + size;
    }
    Ok(match out {
        Some(mut inflated) => {
            inflated.extend_from_slice(&bytes[at..]);
            Cow::Owned(inflated)
        }
        None => Cow::Borrowed(bytes),
    })
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}
