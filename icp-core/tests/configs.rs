//! The committed variant files describe exactly the built-in variants.

use std::path::Path;

use icp_core::variants::{builtin, builtin_names, VariantConfig, VariantSpec};

#[test]
fn config_files_equal_the_builtins() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/variants");
    for name in builtin_names() {
        let path = dir.join(format!("{}.json", name.to_lowercase()));
        let text =
            std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let spec: VariantSpec = serde_json::from_str(&text).unwrap();
        assert_eq!(
            Some(spec.clone()),
            builtin(name, &VariantConfig::default()),
            "{}",
            path.display()
        );
        assert!(spec.build().is_ok());
    }
}
