//! The MATLAB reader path: the fuzzed bytes are the ranges file, beside well-formed angles
//! and poses. Any input must give a dataset or a typed error, never a panic.
#![no_main]

use std::path::Path;

use datasets::marina::{parse, MarinaOptions};
use datasets::matv5::write_doubles;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let angles = write_doubles(&[("angles_baza", 4, 3, &[0.0, 1.0, 2.0, 3.0, 0.0, 1.0, 2.0, 3.0, 0.0, 1.0, 2.0, 3.0])]).unwrap();
    let gps = write_doubles(&[("slam_pose", 3, 3, &[0.0; 9])]).unwrap();
    let _ = parse(
        [(Path::new("angles.mat"), &angles[..]), (Path::new("ranges.mat"), data), (Path::new("gps.mat"), &gps[..])],
        &MarinaOptions::default(),
    );
});
