//! The README's results table is the committed report's, not a hand-typed copy.

use std::path::Path;

fn section(text: &str, title: &str) -> String {
    let start = text
        .find(title)
        .unwrap_or_else(|| panic!("no section {title:?}"));
    let rest = &text[start + title.len()..];
    let end = rest.find("\n## ").unwrap_or(rest.len());
    // Drop the rest of the title line, keep the body.
    let body = &rest[rest.find('\n').unwrap()..end];
    body.trim().to_owned()
}

#[test]
fn readme_marina_table_matches_the_committed_report() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let table = std::fs::read_to_string(root.join("reports/reproduction/marina/table.md")).unwrap();
    let (a, b) = (
        "<!-- marina-plausible:start -->",
        "<!-- marina-plausible:end -->",
    );
    let block = &readme[readme.find(a).unwrap() + a.len()..readme.find(b).unwrap()];
    let expected = format!(
        "{}\n\n{}",
        section(
            &table,
            "## Table 1 layout, pairs with a plausible reference"
        ),
        section(
            &table,
            "## Robust statistics, pairs with a plausible reference"
        )
    );
    assert_eq!(
        block.trim(),
        expected,
        "regenerate with `icp-eval reproduce` and copy the tables"
    );
}
