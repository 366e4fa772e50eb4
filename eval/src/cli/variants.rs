//! `--variants`, `--config` and the options shared by the built-in variants: the variants a
//! command runs.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use datasets::Dataset;
use eval::run::options::BuiltinOptions;
use icp_core::matching::MATCHERS;
use icp_core::variants::{builtin, builtin_names, VariantSpec, TABLE1};
use serde::Deserialize;

#[derive(Args)]
pub(crate) struct VariantArgs {
    /// Built-in variants, comma-separated (listed below and by `icp-eval list`). Default: the
    /// four of Table 1, or none when --config is given.
    #[arg(long, value_delimiter = ',')]
    pub(crate) variants: Option<Vec<String>>,
    /// Variants from a JSON or TOML file: one variant spec, or `variants = [...]`. Taken as
    /// written (the options below apply to the built-in variants only). Repeatable.
    #[arg(long)]
    pub(crate) config: Vec<PathBuf>,
    /// Nearest-neighbour matcher of the built-in variants (a kind listed below; all exact).
    #[arg(long)]
    pub(crate) matcher: Option<String>,
    /// Factor c of the robust threshold c · median of the built-in variants that reject.
    #[arg(long)]
    pub(crate) huber_c: Option<f64>,
    /// Seed of the random selection of the built-in variants that select at random.
    #[arg(long)]
    pub(crate) seed: Option<u64>,
}

/// A variants file: one spec, or a list under `variants`.
#[derive(Deserialize)]
#[serde(untagged)]
pub(crate) enum VariantsFile {
    Many { variants: Vec<VariantSpec> },
    One(Box<VariantSpec>),
}

pub(crate) fn read_variants_file(path: &Path) -> Result<Vec<VariantSpec>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let parsed: VariantsFile = if path.extension().is_some_and(|e| e == "toml") {
        toml::from_str(&text)
            .with_context(|| format!("{} is not a valid variants file", path.display()))?
    } else {
        serde_json::from_str(&text)
            .with_context(|| format!("{} is not a valid variants file", path.display()))?
    };
    let specs = match parsed {
        VariantsFile::Many { variants } => variants,
        VariantsFile::One(spec) => vec![*spec],
    };
    for s in &specs {
        s.validate()
            .with_context(|| format!("variant {} in {}", s.name, path.display()))?;
    }
    Ok(specs)
}

/// The variants to run: the built-in ones named, with the dataset's sensor model (after
/// `--sensor`) and the shared options, then those of the configuration files as written.
pub(crate) fn resolve_variants(args: &VariantArgs, ds: &Dataset) -> Result<Vec<VariantSpec>> {
    if let Some(m) = &args.matcher {
        MATCHERS.find(m).context("--matcher")?;
    }
    let names: Vec<String> = match &args.variants {
        Some(v) => v.clone(),
        None if args.config.is_empty() => TABLE1.iter().map(|s| s.to_string()).collect(),
        None => Vec::new(),
    };
    let options = BuiltinOptions {
        matcher: args.matcher.clone(),
        huber_c: args.huber_c,
        seed: args.seed,
    };
    let mut specs = Vec::new();
    for n in &names {
        let spec = builtin(n).with_context(|| {
            format!(
                "unknown variant {n:?}: expected one of {}, or --config FILE",
                builtin_names().join(", ")
            )
        })?;
        // The shared options apply to the built-in variants, where they have the parameter.
        let name = spec.name.clone();
        specs.push(
            options
                .apply(spec, ds.sensor)
                .with_context(|| format!("variant {name}"))?,
        );
    }
    for path in &args.config {
        specs.extend(read_variants_file(path)?);
    }
    if specs.is_empty() {
        bail!("no variant to run");
    }
    for s in &specs {
        s.validate()
            .with_context(|| format!("variant {}", s.name))?;
    }
    Ok(specs)
}
