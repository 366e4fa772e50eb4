//! `V+causal.nmea`: what the causal smoothed estimator would say live, as NMEA 0183
//! sentences, one group per scan: `ZDA` (the scan's time and date), `VTG` (course over ground,
//! true, and speed over ground in knots and km/h), `ROT` (rate of turn) and `HDT` (heading,
//! true). The talker is `II` (integrated instrumentation): the figures are derived from the
//! scanner, not from a GNSS receiver.
//!
//! The scan's time is `sequence.csv`'s `time_s` taken as seconds since 1970-01-01 00:00:00
//! UTC, so a dataset with relative times (the synthetic harbours, marina) gives dates on
//! 1 January 1970. A scan whose estimate rests on the prior alone (`supported` false) gets its
//! sentences with empty fields (its time still in `ZDA`), `VTG`'s mode `N` and `ROT`'s status `V`; without a reference
//! heading at the first scan the headings are relative, so `HDT`'s heading and `VTG`'s course
//! are left empty. An estimator that gave nothing has no file (`summary.json`'s `sequence`
//! says why).

use crate::error::EvalError;
use crate::measure::report::RunReport;
use crate::render::outdir::OutputDir;
use crate::run::sequence::SequenceRecord;
use crate::run::sequence_setup::SequenceMode;

/// The talker identifier of every sentence.
const TALKER: &str = "II";

/// Knots per metre per second (a knot is 1852 m an hour).
const KNOTS_PER_MPS: f64 = 3600.0 / 1852.0;

/// Decimals of the speeds, angles and rate of turn.
const DECIMALS: usize = 2;

/// Writes `V+causal.nmea` for each causal estimator that gave an estimate.
pub fn write(out: &mut OutputDir, report: &RunReport) -> Result<(), EvalError> {
    let causal = SequenceMode::Causal.suffix();
    for summary in report
        .sequence
        .iter()
        .filter(|s| s.method.ends_with(causal))
    {
        let rows: Vec<&SequenceRecord> = report
            .sequence_scans
            .iter()
            .filter(|r| r.method == summary.method)
            .collect();
        if rows.is_empty() {
            continue;
        }
        let text = sentences(&rows, summary.heading_from_reference);
        out.write(&format!("{}.nmea", summary.method), text.as_bytes())?;
    }
    Ok(())
}

/// The sentences of every scan of one estimator, CRLF-terminated.
pub fn sentences(rows: &[&SequenceRecord], heading_from_reference: bool) -> String {
    let mut s = String::new();
    for r in rows {
        s.push_str(&sentence(&zda(r.time_s)));
        s.push_str(&sentence(&vtg(r, heading_from_reference)));
        s.push_str(&sentence(&rot(r)));
        s.push_str(&sentence(&hdt(r, heading_from_reference)));
    }
    s
}

/// `$BODY*HH\r\n`, `HH` the checksum of `body`.
fn sentence(body: &str) -> String {
    format!("${body}*{:02X}\r\n", checksum(body))
}

/// The XOR of the bytes between `$` and `*`.
fn checksum(body: &str) -> u8 {
    body.bytes().fold(0, |acc, b| acc ^ b)
}

/// `ZDA`: UTC time `hhmmss.ss`, day, month, year, and a zero local zone. Empty time and date
/// fields for a time outside years 0–9999.
fn zda(time_s: f64) -> String {
    let fields = utc(time_s).map_or_else(
        || ",,,".to_owned(),
        |u| {
            format!(
                "{:02}{:02}{:02}.{:02},{:02},{:02},{:04}",
                u.hour, u.minute, u.second, u.centis, u.day, u.month, u.year
            )
        },
    );
    format!("{TALKER}ZDA,{fields},00,00")
}

/// `VTG`: course true, (no magnetic course), speed in knots and km/h, mode `A` or `N`.
fn vtg(r: &SequenceRecord, heading_from_reference: bool) -> String {
    if !valid(r) {
        return format!("{TALKER}VTG,,T,,M,,N,,K,N");
    }
    let cog = if heading_from_reference {
        angle(r.cog_deg)
    } else {
        String::new()
    };
    format!(
        "{TALKER}VTG,{cog},T,,M,{},N,{},K,A",
        fixed(r.sog_mps * KNOTS_PER_MPS),
        fixed(r.sog_mps * 3.6)
    )
}

/// `ROT`: degrees per minute, negative when the bow turns to port; status `A` or `V`.
fn rot(r: &SequenceRecord) -> String {
    if valid(r) {
        format!("{TALKER}ROT,{},A", fixed(r.rot_dps * 60.0))
    } else {
        format!("{TALKER}ROT,,V")
    }
}

/// `HDT`: heading, degrees true.
fn hdt(r: &SequenceRecord, heading_from_reference: bool) -> String {
    if valid(r) && heading_from_reference {
        format!("{TALKER}HDT,{},T", angle(r.hdg_deg))
    } else {
        format!("{TALKER}HDT,,T")
    }
}

/// Whether the scan's figures can be written: its estimate rests on a registration, and they
/// are finite.
fn valid(r: &SequenceRecord) -> bool {
    r.supported
        && [r.sog_mps, r.cog_deg, r.rot_dps, r.hdg_deg]
            .iter()
            .all(|x| x.is_finite())
}

/// `x` to [`DECIMALS`] decimals, without a sign on a value that rounds to zero.
fn fixed(x: f64) -> String {
    let s = format!("{x:.DECIMALS$}");
    if s.trim_start_matches('-')
        .bytes()
        .all(|b| b == b'0' || b == b'.')
    {
        s.trim_start_matches('-').to_owned()
    } else {
        s
    }
}

/// An angle in degrees to [`DECIMALS`] decimals, in [0, 360) after rounding.
fn angle(deg: f64) -> String {
    let scale = 10f64.powi(DECIMALS as i32);
    let rounded = (deg.rem_euclid(360.0) * scale).round() / scale;
    fixed(if rounded >= 360.0 {
        rounded - 360.0
    } else {
        rounded
    })
}

/// A UTC time of day and date, to the hundredth of a second.
#[derive(Debug, PartialEq)]
struct Utc {
    year: i64,
    month: u32,
    day: u32,
    hour: i64,
    minute: i64,
    second: i64,
    centis: i64,
}

/// `time_s` since 1970-01-01 00:00:00 UTC as a date and time, rounded to the hundredth of a
/// second; none outside years 0–9999 (or not finite).
fn utc(time_s: f64) -> Option<Utc> {
    // Years 0–9999 lie within ±3.2e11 s of 1970: beyond, nothing to write.
    if !(time_s.is_finite() && time_s.abs() < 1e12) {
        return None;
    }
    let centis = (time_s * 100.0).round() as i64;
    let per_day = 86_400 * 100;
    let (days, of_day) = (centis.div_euclid(per_day), centis.rem_euclid(per_day));
    let (year, month, day) = civil_from_days(days);
    (0..=9999).contains(&year).then_some(Utc {
        year,
        month,
        day,
        hour: of_day / 360_000,
        minute: of_day / 6_000 % 60,
        second: of_day / 100 % 60,
        centis: of_day % 100,
    })
}

/// The proleptic Gregorian date `days` after 1970-01-01 (Hinnant, "chrono-Compatible
/// Low-Level Date Algorithms", `civil_from_days`).
fn civil_from_days(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let month = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let year = yoe + era * 400 + i64::from(month <= 2);
    (year, month, day)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sentences published with their checksums (the NMEA examples of Dale DePriest's
    /// "NMEA data" page, gpsinformation.org): the XOR between `$` and `*`.
    #[test]
    fn checksums_of_published_sentences() {
        assert_eq!(checksum("GPVTG,054.7,T,034.4,M,005.5,N,010.2,K"), 0x48);
        assert_eq!(
            checksum("GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,"),
            0x47
        );
        assert_eq!(
            sentence("GPVTG,054.7,T,034.4,M,005.5,N,010.2,K"),
            "$GPVTG,054.7,T,034.4,M,005.5,N,010.2,K*48\r\n"
        );
    }

    #[test]
    fn times_become_utc_dates() {
        assert_eq!(zda(0.0), "IIZDA,000000.00,01,01,1970,00,00");
        // 2000-02-29 00:00:00 UTC, a leap day, and 12 h 0 min 1.25 s after it.
        assert_eq!(zda(951_782_400.0), "IIZDA,000000.00,29,02,2000,00,00");
        assert_eq!(zda(951_825_601.25), "IIZDA,120001.25,29,02,2000,00,00");
        // Rounding to the hundredth carries into the next day.
        assert_eq!(zda(86_399.996), "IIZDA,000000.00,02,01,1970,00,00");
        assert_eq!(zda(-1.0), "IIZDA,235959.00,31,12,1969,00,00");
        assert_eq!(zda(f64::NAN), "IIZDA,,,,,00,00");
        assert_eq!(zda(1e13), "IIZDA,,,,,00,00");
    }

    #[test]
    fn angles_and_figures_are_rounded_without_a_signed_zero() {
        assert_eq!(angle(359.996), "0.00");
        assert_eq!(angle(-90.0), "270.00");
        assert_eq!(fixed(-0.001), "0.00");
        assert_eq!(fixed(-0.006), "-0.01");
    }
}
