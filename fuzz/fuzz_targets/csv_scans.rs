//! Our CSV parser on arbitrary bytes (as scans.csv, and as poses.csv and odometry.csv beside a
//! fixed scans file): a dataset or a typed error, never a panic.
#![no_main]

use std::path::Path;

use datasets::csvdir::{parse, DatasetMeta};
use libfuzzer_sys::fuzz_target;

const SCANS: &[u8] = b"scan,timestamp_s,range_m,bearing_rad\n0,0,5,0\n0,0,6,1\n0,0,7,2\n1,1,5,0\n1,1,6,1\n1,1,7,2\n";

fuzz_target!(|data: &[u8]| {
    let meta = DatasetMeta::default();
    let _ = parse((Path::new("scans.csv"), data), None, None, &meta, "fuzz");
    let _ = parse((Path::new("scans.csv"), SCANS), Some((Path::new("poses.csv"), data)), None, &meta, "fuzz");
    let _ = parse((Path::new("scans.csv"), SCANS), None, Some((Path::new("odometry.csv"), data)), &meta, "fuzz");
});
