//! CARMEN logs: the classic public 2D laser format (`FLASER` lines), plain or gzipped.
//!
//! `FLASER n r_1 … r_n x y θ odom_x odom_y odom_θ ipc_timestamp ipc_hostname logger_timestamp`
//!
//! Ranges are metres; bearings span the field of view counter-clockwise from its right edge,
//! `n` beams over 180° by default. A reading at or beyond the maximum range is a no-return.
//! `ODOM x y θ tv rv accel ipc_timestamp …` lines are read as the robot's odometry stream
//! (below). Other message types (`PARAM`, `RLASER`, …) and `#` comments are skipped and
//! counted.
//!
//! `x y θ` is the laser's own pose (so the scanner offset is the identity): the reference, by
//! default [`ReferenceKind::SlamCorrected`] as in the public "corrected" logs
//! ([`CarmenOptions::reference_kind`] says otherwise for a raw log, whose poses are
//! odometry). `odom_x odom_y odom_θ` is the robot's odometry pose, kept as the odometry
//! channel; the laser sits `robot_frontlaser_offset` ahead of it (a `PARAM` line, not read).
//! Some corrected logs overwrite the odometry fields with the corrected poses (`aces`). Then,
//! when the `ODOM` lines cover every scan, the odometry channel is their own motion instead
//! (see the `odom_lines` module: increments chained, re-anchoring lines dropped, interpolated
//! over at most [`MAX_ODOM_GAP_S`](crate::MAX_ODOM_GAP_S)), and the loader says so
//! ([`LoadWarning::OdometryFromOdomLines`](crate::LoadWarning)); otherwise it warns that
//! there is no independent odometry
//! ([`LoadWarning::OdometryEqualsReference`](crate::LoadWarning)).

use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use icp_core::{BearingSense, Scan, SensorModel};
use sha2::{Digest, Sha256};

use crate::dataset::{
    nominal_dt_s, Dataset, FileProvenance, Pose2, Provenance, ReferenceKind, ReferencePose,
};
use crate::odom_lines::OdomLines;
use crate::{DatasetError, LoadWarning};

/// The laser's angular layout and range limit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CarmenOptions {
    /// Field of view, degrees: the first beam on its right edge, the others counter-clockwise,
    /// as far apart as CARMEN's reader takes them (1° for 180 or 181 beams over 180°: see
    /// `docs/formats.md`).
    pub fov_deg: f64,
    /// Readings at or beyond this range are no-returns, metres.
    pub max_range_m: f64,
    /// The sensor model for the weights (default: [`SICK_LMS2XX`]).
    pub sensor: SensorModel,
    /// What the logged laser poses are (default: [`ReferenceKind::SlamCorrected`], the
    /// public "corrected" logs; [`ReferenceKind::Odometry`] for a raw log).
    pub reference_kind: ReferenceKind,
}

impl Default for CarmenOptions {
    fn default() -> Self {
        Self {
            fov_deg: 180.0,
            max_range_m: 50.0,
            sensor: SICK_LMS2XX,
            reference_kind: ReferenceKind::SlamCorrected,
        }
    }
}

/// A SICK LMS 2xx-class laser, the scanner of the classic CARMEN logs (180 or 181 beams at
/// 1°, ranges to 50–80 m): `σ_r = 1 cm` at every range, `σ_α = 0.5°`.
///
/// - `σ_r`: the 10 mm range resolution of the LMS 2xx in the cm mode that ranges beyond 8 m
///   need (81.92 m at 10 mm; Player `sicklms200` driver documentation), which is also the
///   order of the statistical error (1σ) SICK states for its later families (LMS1xx 12 mm
///   typical; LMS5xx 6–14 mm; SICK support article "Measurement Errors LMSxxx"). Constant, not
///   proportional to the range as the Sweep's: at 20 m the Sweep model says 8.5 cm.
/// - `σ_α`: the beam divergence stands for the bearing error here as for the Sweep. SICK gives
///   4.6–11 mrad (0.26–0.63°) for the LMS5xx and 15 mrad (0.86°) for the LMS1xx (operating
///   instructions, "Beam diameter"); 0.5° lies within that span.
///
/// The LMS 2xx technical description itself was not at hand when these were chosen; correct
/// them for a known unit with `--sensor`.
pub const SICK_LMS2XX: SensorModel = SensorModel {
    sigma_r_const_m: 0.01,
    sigma_r_per_m: 0.0,
    sigma_alpha_rad: 0.5 * std::f64::consts::PI / 180.0,
};

/// The angular resolutions of the SICK LMS 2xx, degrees.
const SICK_RESOLUTIONS_DEG: [f64; 3] = [1.0, 0.5, 0.25];

/// The angle between two beams of a `FLASER` line of `n` readings over `fov_deg`, degrees, as
/// CARMEN's own reader takes it (`carmen_laser_guess_angle_increment`, `readlog.c`): a line
/// carries no angles, and a SICK LMS 2xx over 180° sends 181 readings 1° apart, or 180 (the
/// last dropped, a field of view of 179°), likewise 361 or 360 at 0.5°. So the beams are
/// `fov/n` apart where that is one of the laser's resolutions (the last beam dropped), else
/// `fov/(n − 1)` (the first and last beams on the edges). Taken as `fov/(n − 1)` for every
/// `n`, the 180 beams of the public logs were 1.0056° apart and every rotation came out
/// 0.56 % too large (measured on aces: `docs/formats.md`).
fn beam_spacing_deg(fov_deg: f64, n: usize) -> f64 {
    if n < 2 {
        return 0.0;
    }
    let dropped_last = fov_deg / n as f64;
    if SICK_RESOLUTIONS_DEG
        .iter()
        .any(|r| (dropped_last - r).abs() < 1e-9)
    {
        dropped_last
    } else {
        fov_deg / (n - 1) as f64
    }
}

/// What a parse read and skipped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CarmenCounts {
    /// `FLASER` lines read.
    pub scans: usize,
    /// `ODOM` lines read.
    pub odom_lines: usize,
    /// Other lines (other messages, comments, blank lines) skipped.
    pub skipped_lines: usize,
}

/// Reads a CARMEN log from `path` (`.log`, or gzip detected by its magic bytes).
pub fn load(path: &Path, options: &CarmenOptions) -> Result<Dataset, DatasetError> {
    let bytes = std::fs::read(path).map_err(|source| DatasetError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let sha256 = Sha256::digest(&bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    let (mut ds, _) = if bytes.starts_with(&[0x1f, 0x8b]) {
        parse(path, flate2::read::GzDecoder::new(&bytes[..]), options)?
    } else {
        parse(path, &bytes[..], options)?
    };
    ds.provenance.files = vec![FileProvenance {
        path: path.to_path_buf(),
        sha256,
        matches_pinned: None,
    }];
    Ok(ds)
}

/// Parses a CARMEN log; `path` names it in errors.
pub fn parse<R: Read>(
    path: &Path,
    reader: R,
    options: &CarmenOptions,
) -> Result<(Dataset, CarmenCounts), DatasetError> {
    let check = |name: &'static str, value: f64, ok: bool| {
        if ok {
            Ok(())
        } else {
            Err(DatasetError::InvalidParameter {
                name,
                value,
                reason: "out of range for a CARMEN layout",
            })
        }
    };
    check(
        "fov_deg",
        options.fov_deg,
        options.fov_deg.is_finite() && options.fov_deg > 0.0 && options.fov_deg <= 360.0,
    )?;
    check(
        "max_range_m",
        options.max_range_m,
        options.max_range_m.is_finite() && options.max_range_m > 0.0,
    )?;
    DatasetError::check_sensor(&options.sensor)?;
    let mut scans = Vec::new();
    let mut reference = Vec::new();
    let mut odometry = Vec::new();
    let mut odom_lines = OdomLines::default();
    let mut counts = CarmenCounts::default();
    let at = |line: usize, what: String| DatasetError::Parse {
        path: path.to_path_buf(),
        line,
        what,
    };
    for (i, line) in BufReader::new(reader).lines().enumerate() {
        let n_line = i + 1;
        let line = line.map_err(|e| at(n_line, format!("unreadable line: {e}")))?;
        let mut fields = line.split_whitespace();
        let tag = fields.next();
        if tag != Some("FLASER") && tag != Some("ODOM") {
            counts.skipped_lines += 1;
            continue;
        }
        let fields: Vec<&str> = fields.collect();
        let num = |k: usize, what: &str| -> Result<f64, DatasetError> {
            let f = fields
                .get(k)
                .ok_or_else(|| at(n_line, format!("missing field {what} (field {})", k + 2)))?;
            let v: f64 = f
                .parse()
                .map_err(|_| at(n_line, format!("{what} is not a number: {f:?}")))?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(at(n_line, format!("{what} is not finite: {f:?}")))
            }
        };
        if tag == Some("ODOM") {
            // x y θ tv rv accel ipc_timestamp (host and logger timestamp not read).
            let pose = Pose2 {
                x_m: num(0, "odom x")?,
                y_m: num(1, "odom y")?,
                yaw_rad: num(2, "odom theta")?,
            };
            odom_lines.push(num(6, "odom ipc_timestamp")?, pose);
            counts.odom_lines += 1;
            continue;
        }
        let n_f = num(0, "the reading count")?;
        if n_f < 0.0 || n_f.fract() != 0.0 || n_f > 100_000.0 {
            return Err(at(
                n_line,
                format!("the reading count {n_f} is not a count"),
            ));
        }
        let n = n_f as usize;
        // n ranges, then x y θ, odometry x y θ, ipc timestamp, host, logger timestamp.
        if fields.len() < n + 10 {
            return Err(at(
                n_line,
                format!(
                    "{} fields after the count, {} expected for {n} readings",
                    fields.len() - 1,
                    n + 9
                ),
            ));
        }
        let mut ranges = Vec::with_capacity(n);
        for k in 0..n {
            let r = num(1 + k, &format!("reading {k}"))?;
            if r < 0.0 {
                return Err(at(n_line, format!("reading {k} is negative: {r}")));
            }
            ranges.push(if r >= options.max_range_m {
                f64::NAN
            } else {
                r
            });
        }
        let step = beam_spacing_deg(options.fov_deg, n);
        let bearings: Vec<f64> = (0..n)
            .map(|k| (-0.5 * options.fov_deg + step * k as f64).to_radians())
            .collect();
        let (x_m, y_m, theta) = (num(n + 1, "x")?, num(n + 2, "y")?, num(n + 3, "theta")?);
        odometry.push(Pose2 {
            x_m: num(n + 4, "odom_x")?,
            y_m: num(n + 5, "odom_y")?,
            yaw_rad: num(n + 6, "odom_theta")?,
        });
        let timestamp = num(n + 7, "ipc_timestamp")?;
        let scan = Scan::from_polar(&ranges, &bearings)
            .and_then(|s| s.with_timestamp(timestamp))
            .map_err(|e| at(n_line, e.to_string()))?;
        scans.push(scan);
        reference.push(ReferencePose {
            x_m,
            y_m,
            heading_rad: theta,
            scan_yaw_rad: Some(theta),
        });
        counts.scans += 1;
    }
    if scans.is_empty() {
        return Err(DatasetError::BadValue {
            path: path.to_path_buf(),
            what: format!(
                "no FLASER line in {} lines: not a CARMEN laser log",
                counts.skipped_lines
            ),
        });
    }
    let (dt_s, assumed) = nominal_dt_s(&scans);
    let times_s: Vec<Option<f64>> = scans.iter().map(Scan::timestamp_s).collect();
    let ds = Dataset {
        provenance: Provenance {
            name: format!(
                "carmen:{}",
                path.file_name().map_or_else(
                    || path.display().to_string(),
                    |f| f.to_string_lossy().into_owned()
                )
            ),
            description: format!(
                "CARMEN log {} ({} FLASER scans, {}° field of view)",
                path.display(),
                counts.scans,
                options.fov_deg
            ),
            files: Vec::new(),
        },
        scans,
        reference: Some(reference),
        reference_kind: Some(options.reference_kind),
        odometry: Some(odometry),
        scanner_offset: Some(Pose2::IDENTITY),
        reference_heading_sense: BearingSense::CounterClockwise,
        // A FLASER line does not say how long its sweep took.
        sweep_s: None,
        dt_s,
        sensor: options.sensor,
        bearing_sense: BearingSense::CounterClockwise,
        // A CARMEN log carries no noise figures.
        warnings: assumed
            .into_iter()
            .chain(
                (options.sensor == SICK_LMS2XX).then(|| LoadWarning::AssumedSensorModel {
                    sensor: SICK_LMS2XX,
                    of: "a SICK LMS 2xx".to_owned(),
                }),
            )
            .collect(),
        first_scans: None,
    }
    .checked();
    Ok((with_odom_lines(ds, &odom_lines, &times_s), counts))
}

/// `ds` with the `ODOM` lines' motion as its odometry when its `FLASER` odometry repeats the
/// reference and the lines cover every scan with motion of their own (see the module doc).
fn with_odom_lines(mut ds: Dataset, lines: &OdomLines, times_s: &[Option<f64>]) -> Dataset {
    let Some(k) = ds
        .warnings
        .iter()
        .position(|w| matches!(w, LoadWarning::OdometryEqualsReference { .. }))
    else {
        return ds;
    };
    let Some(odometry) = lines.at_each(times_s) else {
        return ds;
    };
    let fields = ds.odometry.replace(odometry);
    if ds.odometry_equals_reference().is_some() {
        ds.odometry = fields;
    } else {
        ds.warnings[k] = LoadWarning::OdometryFromOdomLines {
            lines: lines.lines,
            reanchored: lines.reanchored,
        };
    }
    ds
}
