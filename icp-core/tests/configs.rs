//! Every variant file of `configs/variants/` is a built-in variant, and every built-in variant
//! is a file there: the files are the one source of the built-in variants.

use std::path::Path;

use icp_core::variants::{builtin, builtin_names};

#[test]
fn every_json_config_is_built_in_and_every_builtin_has_its_file() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/variants");
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    files.sort();
    let mut names: Vec<String> = builtin_names().iter().map(|n| n.to_lowercase()).collect();
    names.sort();
    assert_eq!(files, names);
    for name in builtin_names() {
        assert!(builtin(&name).unwrap().build().is_ok(), "{name}");
    }
}
