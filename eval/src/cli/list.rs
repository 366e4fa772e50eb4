//! `icp-eval list`: the built-in variants and every stage kind with its parameters, generated
//! from the registries of icp-core (nothing here is written by hand).

use std::fmt::Write as _;

use icp_core::registry::{FamilyDoc, ParamDoc, SectionDoc};
use std::process::ExitCode;

use anyhow::Result;
use icp_core::variants::{builtins, section_docs, stage_families, VariantSpec};

/// The listing of `variants`, the stage `families` and the other `sections`.
pub(crate) fn listing(
    variants: &[VariantSpec],
    families: &[FamilyDoc],
    sections: &[SectionDoc],
) -> String {
    let mut out = String::from("Built-in variants (icp-eval run --variants NAME,...):\n");
    let width = variants.iter().map(|v| v.name.len()).max().unwrap_or(0);
    for v in variants {
        let _ = writeln!(
            out,
            "  {:width$}  {}",
            v.name,
            v.source.as_deref().unwrap_or_default()
        );
    }
    out.push_str(
        "\nStages of a variant configuration (configs/variants/*.json): each is \
         {\"kind\": NAME, parameters...}, or just \"NAME\" with every parameter at its default.\n",
    );
    for family in families {
        let _ = writeln!(out, "\n{}: {}", family.name, family.summary);
        for kind in &family.kinds {
            let _ = writeln!(out, "  {}: {}", kind.name, kind.summary);
            parameters(&mut out, &kind.parameters);
        }
    }
    out.push_str("\nOther sections:\n");
    for section in sections {
        let _ = writeln!(out, "\n{}: {}", section.name, section.summary);
        parameters(&mut out, &section.parameters);
    }
    out
}

fn parameters(out: &mut String, parameters: &[ParamDoc]) {
    for p in parameters {
        let _ = writeln!(
            out,
            "      {} ({}, default {}): {}",
            p.name, p.type_name, p.default, p.description
        );
    }
}

pub(crate) fn list() -> Result<ExitCode> {
    print!(
        "{}",
        listing(&builtins(), &stage_families(), &section_docs())
    );
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use icp_core::variants::{builtins, section_docs, stage_families};

    #[test]
    fn every_kind_and_parameter_is_listed() {
        let text = listing(&builtins(), &stage_families(), &section_docs());
        for v in builtins() {
            assert!(text.contains(&v.name), "{}", v.name);
        }
        for family in stage_families() {
            for kind in &family.kinds {
                assert!(
                    text.contains(&format!("  {}: ", kind.name)),
                    "{}",
                    kind.name
                );
                for p in &kind.parameters {
                    assert!(text.contains(&format!("      {} (", p.name)), "{}", p.name);
                }
            }
        }
        assert!(text.contains("      radius_m (number, default 1.0): "));
        assert!(text
            .contains("      kernel (huber | tukey | cauchy | geman_mcclure, default \"huber\")"));
    }
}
