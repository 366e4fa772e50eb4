//! The CARMEN parser on arbitrary bytes: a dataset or a typed error, never a panic.
#![no_main]

use std::path::Path;

use datasets::carmen::{parse, CarmenOptions};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = parse(Path::new("fuzz.log"), data, &CarmenOptions::default());
});
