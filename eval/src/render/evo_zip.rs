//! evo result files (`evo_res` reads them): a zip holding `info.json`, `stats.json`,
//! `error_array.npy`, `timestamps.npy` and `seconds_from_start.npy`, laid out as evo's
//! `tools/file_interface.py` `save_res_file` writes a `core/result.py` `Result`. The bytes are
//! deterministic: entries in a fixed order, every entry dated 1980-01-01 00:00:00 (the zip
//! epoch) with fixed permissions, JSON with keys in a fixed order.

use std::io::Write as _;

use serde::Serialize;

use crate::error::EvalError;
use crate::measure::trajectory_metrics::EvoStats;

/// What evo's `Result.info` holds (`core/metrics.py` `PE.get_result`): `evo_res` groups
/// results by `title`, names each by `est_name` and labels the axis with `label`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EvoInfo {
    /// The metric, the same for every result meant to be compared (e.g. "SOG error per pair").
    pub title: String,
    /// The reference's name.
    pub ref_name: String,
    /// The estimate's name (the variant).
    pub est_name: String,
    /// The axis label, with the unit (e.g. "SOG error (m/s)").
    pub label: String,
}

/// One evo result: an error per timestamp.
#[derive(Clone, Debug, PartialEq)]
pub struct EvoResult {
    /// Its `info.json`.
    pub info: EvoInfo,
    /// The errors.
    pub errors: Vec<f64>,
    /// The time of each error, s (the same clock as the TUM files).
    pub timestamps_s: Vec<f64>,
}

/// A 1-D little-endian float64 array in NumPy's `.npy` format, version 1.0: the magic
/// `\x93NUMPY`, version bytes 1 0, a little-endian u16 header length, the header dict padded
/// with spaces to a multiple of 64 bytes and ended by a newline, then the data (what
/// `numpy.save` writes for a float64 vector).
pub fn npy_f8(values: &[f64]) -> Vec<u8> {
    let dict = format!(
        "{{'descr': '<f8', 'fortran_order': False, 'shape': ({},), }}",
        values.len()
    );
    const PREAMBLE: usize = 10;
    let unpadded = PREAMBLE + dict.len() + 1;
    let padded = unpadded.div_ceil(64) * 64;
    let mut header = dict;
    header.push_str(&" ".repeat(padded - unpadded));
    header.push('\n');
    let mut out = Vec::with_capacity(padded + 8 * values.len());
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    // The dict is at most a few hundred bytes: a u16 always holds it.
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// The zip of `result`. `None` when it has no errors or a value is not finite (evo's
/// statistics would be undefined).
pub fn result_zip(result: &EvoResult) -> Result<Option<Vec<u8>>, EvalError> {
    let Some(stats) = EvoStats::of(&result.errors) else {
        return Ok(None);
    };
    let first = result.timestamps_s.first().copied().unwrap_or(0.0);
    let from_start: Vec<f64> = result.timestamps_s.iter().map(|t| t - first).collect();
    let entries: [(&str, Vec<u8>); 5] = [
        ("info.json", to_json(&result.info)?),
        ("stats.json", to_json(&stats)?),
        ("error_array.npy", npy_f8(&result.errors)),
        ("timestamps.npy", npy_f8(&result.timestamps_s)),
        ("seconds_from_start.npy", npy_f8(&from_start)),
    ];
    let zip_error = |e: zip::result::ZipError| EvalError::Serialize(format!("evo zip: {e}"));
    let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .last_modified_time(zip::DateTime::default())
        .unix_permissions(0o644);
    for (name, bytes) in entries {
        w.start_file(name, options).map_err(zip_error)?;
        w.write_all(&bytes)
            .map_err(|e| EvalError::Serialize(format!("evo zip {name}: {e}")))?;
    }
    Ok(Some(w.finish().map_err(zip_error)?.into_inner()))
}

fn to_json<T: Serialize>(value: &T) -> Result<Vec<u8>, EvalError> {
    serde_json::to_vec(value).map_err(|e| EvalError::Serialize(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_header_is_numpys() {
        // numpy.save(b, numpy.array([1.5, 2.0])) writes exactly this header (numpy 1.x/2.x).
        let mut want =
            b"\x93NUMPY\x01\x00v\x00{'descr': '<f8', 'fortran_order': False, 'shape': (2,), }"
                .to_vec();
        want.resize(127, b' ');
        want.push(b'\n');
        want.extend_from_slice(&1.5f64.to_le_bytes());
        want.extend_from_slice(&2.0f64.to_le_bytes());
        assert_eq!(npy_f8(&[1.5, 2.0]), want);
        assert_eq!(npy_f8(&[]).len() % 64, 0);
        assert_eq!(npy_f8(&vec![0.0; 123_456]).len(), 128 + 8 * 123_456);
    }
}
