//! The marina loader on the real files (ignored unless `--include-ignored`, then failing when
//! they are absent) and on broken inputs made here.

use std::path::Path;

use datasets::marina::{self, MarinaOptions};
use datasets::matv5::write_doubles;
use datasets::DatasetError;

#[path = "common/data.rs"]
mod data;

#[test]
#[ignore = "needs the marina data (ICP_DATA_DIR): run with --include-ignored"]
fn real_files_load_with_the_expected_counts() {
    let dir = data::marina_dir();
    let ds = marina::load(&dir, &MarinaOptions::default()).unwrap();
    assert_eq!(ds.scans.len(), 177);
    let counts: Vec<usize> = ds.scans.iter().map(|s| s.len()).collect();
    assert_eq!(counts.iter().filter(|&&c| c > 0).count(), 176);
    assert_eq!(counts[176], 0, "the last scan is empty");
    // Measured on the pinned files: 75,576 valid returns, 141 to 706 per non-empty scan.
    assert_eq!(counts.iter().sum::<usize>(), 75_576);
    assert_eq!(counts[..176].iter().min(), Some(&141));
    assert_eq!(counts.iter().max(), Some(&706));
    assert_eq!(counts[0], 676);
    // Every reading is a return or a counted no-return.
    assert!(ds.scans.iter().all(|s| s.len() + s.no_returns() == 750));
    let (pairs, skipped) = ds.consecutive_pairs();
    assert_eq!(pairs.len(), 175);
    assert_eq!(skipped.len(), 1);
    assert_eq!(
        (skipped[0].pair.source, skipped[0].pair.reference),
        (175, 176)
    );
    assert!(ds
        .provenance
        .files
        .iter()
        .all(|f| f.matches_pinned == Some(true)));
    assert_eq!(ds.reference.as_ref().map(|r| r.len()), Some(177));
    assert_eq!(ds.pair_dt_s(pairs[3]), 1.0);
    // GNSS positions and a heading, no odometry, no known lever arm; median steps of 1.25 m
    // and 0.09°, which the paper's identity start handles: no warning.
    assert_eq!(
        ds.reference_kind,
        Some(datasets::ReferenceKind::GnssPositions)
    );
    assert_eq!((ds.odometry, ds.scanner_offset), (None, None));
    assert_eq!(ds.warnings, vec![]);
}

fn parse(angles: &[u8], ranges: &[u8], gps: &[u8]) -> Result<datasets::Dataset, DatasetError> {
    marina::parse(
        [
            (Path::new("angles.mat"), angles),
            (Path::new("ranges.mat"), ranges),
            (Path::new("gps.mat"), gps),
        ],
        &MarinaOptions::default(),
    )
}

/// A small well-formed set: 4 beams × 3 scans, the last scan empty.
fn small() -> (Vec<u8>, Vec<u8>, Vec<u8>) {
    let angles: Vec<f64> = (0..12).map(|i| (i % 4) as f64 * 1.5).collect();
    let ranges = [
        5.0,
        6.0,
        7.0,
        f64::NAN,
        5.1,
        6.1,
        0.0,
        8.0,
        f64::NAN,
        f64::NAN,
        0.0,
        0.0,
    ];
    let pose = [0.0, 1.0, 2.0, 0.0, 0.1, 0.2, 4.7, 4.7, 4.8];
    (
        write_doubles(&[("angles_baza", 4, 3, &angles)]).unwrap(),
        write_doubles(&[("ranges_baza", 4, 3, &ranges)]).unwrap(),
        write_doubles(&[("slam_pose", 3, 3, &pose)]).unwrap(),
    )
}

#[test]
fn small_well_formed_files_parse() {
    let (a, r, g) = small();
    let ds = parse(&a, &r, &g).unwrap();
    let counts: Vec<_> = ds.scans.iter().map(|s| (s.len(), s.no_returns())).collect();
    assert_eq!(counts, vec![(3, 1), (3, 1), (0, 4)]);
    let (pairs, skipped) = ds.consecutive_pairs();
    assert_eq!(pairs.len(), 1);
    assert!(
        skipped[0].reason.contains("scan 2 has 0 valid returns"),
        "{}",
        skipped[0].reason
    );
    assert_eq!(ds.reference.unwrap()[1].y_m, 0.1);
}

/// The file with each top-level element after the header wrapped in a compressed element
/// (type 15, a zlib stream of the element), as MATLAB writes by default.
fn compressed(file: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut out = file[..128].to_vec();
    let mut at = 128;
    while at + 8 <= file.len() {
        let size = u32::from_le_bytes(file[at + 4..at + 8].try_into().unwrap()) as usize;
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&file[at..at + 8 + size]).unwrap();
        let z = z.finish().unwrap();
        out.extend_from_slice(&15u32.to_le_bytes());
        out.extend_from_slice(&(z.len() as u32).to_le_bytes());
        out.extend_from_slice(&z);
        at += 8 + size;
    }
    out
}

#[test]
fn compressed_files_read_like_plain_ones() {
    let (a, r, g) = small();
    let plain = parse(&a, &r, &g).unwrap();
    let (ca, cr, cg) = (compressed(&a), compressed(&r), compressed(&g));
    assert_ne!(cr, r, "the ranges are stored compressed");
    // Compared through Debug, which prints every f64 exactly (Dataset is not PartialEq).
    assert_eq!(
        format!("{:?}", parse(&ca, &cr, &cg).unwrap()),
        format!("{plain:?}")
    );
    // A compressed element after a plain one, and a plain one after a compressed one.
    let two = write_doubles(&[
        ("other", 1, 2, &[1.0, 2.0]),
        ("ranges_baza", 4, 3, &[5.0; 12]),
    ]);
    let two = two.unwrap();
    let mut mixed = compressed(&two);
    let first_len = 8 + u32::from_le_bytes(two[132..136].try_into().unwrap()) as usize;
    let z_len = 8 + u32::from_le_bytes(mixed[132..136].try_into().unwrap()) as usize;
    mixed.truncate(128);
    mixed.extend_from_slice(&two[128..128 + first_len]);
    mixed.extend_from_slice(&compressed(&two)[128 + z_len..]);
    let ds = parse(&a, &mixed, &g).unwrap();
    assert_eq!(ds.scans[0].len(), 4);
}

#[test]
fn a_compressed_element_that_does_not_inflate_is_named() {
    let (a, r, g) = small();
    let mut bad = compressed(&r);
    let end = bad.len();
    bad[140..end].fill(0xA5); // the zlib stream past its first bytes
    let e = parse(&a, &bad, &g).unwrap_err().to_string();
    assert!(
        e.starts_with(
            "ranges.mat is not a readable MATLAB v5 file: the compressed data element at byte 128 does not inflate: "
        ),
        "{e}"
    );
}

#[test]
fn wrong_variable_name_is_named() {
    let (a, _, g) = small();
    let r = write_doubles(&[("ranges", 4, 3, &[1.0; 12])]).unwrap();
    match parse(&a, &r, &g) {
        Err(DatasetError::MissingVariable { path, name, found }) => {
            assert_eq!(path, Path::new("ranges.mat"));
            assert_eq!(name, "ranges_baza");
            assert_eq!(found, vec!["ranges".to_string()]);
        }
        other => panic!("unexpected {other:?}"),
    }
}

#[test]
fn mismatched_shapes_are_refused() {
    let (a, _, g) = small();
    let r = write_doubles(&[("ranges_baza", 4, 2, &[1.0; 8])]).unwrap();
    let e = parse(&a, &r, &g).unwrap_err();
    assert!(
        matches!(&e, DatasetError::Shape { name, got, .. } if name == "ranges_baza" && got == &vec![4, 2]),
        "{e}"
    );
    let (a, r, _) = small();
    let g = write_doubles(&[("slam_pose", 2, 3, &[0.0; 6])]).unwrap();
    let e = parse(&a, &r, &g).unwrap_err();
    assert!(
        matches!(&e, DatasetError::Shape { name, .. } if name == "slam_pose"),
        "{e}"
    );
    assert!(e.to_string().contains("gps.mat"), "{e}");
}

#[test]
fn bad_values_are_refused() {
    let (a, _, g) = small();
    let mut ranges = [5.0; 12];
    ranges[5] = -1.0;
    let r = write_doubles(&[("ranges_baza", 4, 3, &ranges)]).unwrap();
    let e = parse(&a, &r, &g).unwrap_err();
    assert!(matches!(e, DatasetError::Scan { scan: 1, .. }), "{e}");
    assert!(e.to_string().contains("negative range"), "{e}");
    let (a, r, _) = small();
    let mut pose = [0.0; 9];
    pose[4] = f64::INFINITY;
    let g = write_doubles(&[("slam_pose", 3, 3, &pose)]).unwrap();
    assert!(matches!(
        parse(&a, &r, &g),
        Err(DatasetError::BadValue { .. })
    ));
}

#[test]
fn truncated_empty_and_foreign_files_are_parse_errors() {
    let (a, r, g) = small();
    for cut in [0, 10, 127, 128, 140, a.len() / 2, a.len() - 3] {
        let e = parse(&a[..cut], &r, &g).unwrap_err();
        assert!(
            matches!(
                &e,
                DatasetError::MatParse { .. } | DatasetError::MissingVariable { .. }
            ),
            "cut {cut}: {e}"
        );
    }
    let mut foreign = b"PK\x03\x04 this is a zip".to_vec();
    foreign.resize(300, 0);
    assert!(matches!(
        parse(&a, &foreign, &g),
        Err(DatasetError::MatParse { .. })
    ));
}

#[test]
#[ignore = "needs the marina data (ICP_DATA_DIR): run with --include-ignored"]
fn truncated_real_file_is_a_parse_error() {
    let dir = data::marina_dir();
    let bytes = std::fs::read(dir.join("ranges.mat")).unwrap();
    let (a, g) = (
        std::fs::read(dir.join("angles.mat")).unwrap(),
        std::fs::read(dir.join("gps.mat")).unwrap(),
    );
    for cut in [200, bytes.len() / 3, bytes.len() - 1] {
        let e = parse(&a, &bytes[..cut], &g).unwrap_err();
        assert!(
            matches!(
                &e,
                DatasetError::MatParse { .. } | DatasetError::MissingVariable { .. }
            ),
            "cut {cut}: {e}"
        );
    }
}

#[test]
fn missing_directory_says_where_it_looked_and_how_to_fetch() {
    // An explicit --data-dir is the only place looked at; without it, the environment
    // variable and then ./datasets.
    let explicit = marina::candidate_dirs(Some(Path::new("/nonexistent/a")), Some(Path::new("/x")));
    assert_eq!(
        explicit,
        vec![
            Path::new("/nonexistent/a/marina"),
            Path::new("/nonexistent/a")
        ]
    );
    let looked = marina::candidate_dirs(None, Some(Path::new("/nonexistent/b")));
    assert_eq!(looked[0], Path::new("/nonexistent/b/marina"));
    assert_eq!(looked[2], Path::new("datasets/marina"));
    let err = marina::load(Path::new("/nonexistent/a"), &MarinaOptions::default()).unwrap_err();
    assert!(matches!(err, DatasetError::Io { .. }));
    let e = DatasetError::NotFound {
        dataset: "marina",
        looked,
        hint: marina::FETCH_HINT.into(),
    };
    let msg = e.to_string();
    assert!(
        msg.contains("/nonexistent/b/marina") && msg.contains("fetch-marina.sh"),
        "{msg}"
    );
}

#[test]
fn every_file_has_a_pinned_checksum() {
    for (file, _) in marina::FILES {
        let sum = marina::pinned_sha256(file).unwrap_or_else(|| panic!("{file} is not pinned"));
        assert_eq!(sum.len(), 64);
        assert!(sum.chars().all(|c| c.is_ascii_hexdigit()));
    }
    assert_eq!(marina::pinned_sha256("other.mat"), None);
}
