//! Sharded runs (`--shard K/N`, the Slurm and Kubernetes variables) merged by `icp-eval
//! merge` equal a single run byte for byte, timing fields aside; the merge refuses parts
//! that are missing, given twice or of another plan; re-running a shard rewrites the same
//! part.

mod common;
use common::icp_eval;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use eval::shard::resolve;
use eval::shard::Shard;
use eval::shard::ShardError;
use eval::shard::ShardOrigin;

fn ok(o: Output) -> Output {
    assert!(
        o.status.success(),
        "icp-eval failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn args(base: &[&str], more: &[&str]) -> Vec<String> {
    base.iter().chain(more).map(|s| s.to_string()).collect()
}

/// Runs `base` whole into `dir/single`, and for each of `shard_counts` in that many shards
/// merged into `dir/nN/merged`, and checks each merged run equals the single run (timing
/// aside); per count, the merged directory and how many files were compared.
fn merged_equal_single(base: &[&str], dir: &Path, shard_counts: &[usize]) -> Vec<(PathBuf, usize)> {
    let single = dir.join("single");
    ok(icp_eval(&args(base, &["--out", single.to_str().unwrap()])));
    shard_counts
        .iter()
        .map(|&n| {
            let merged = merge_shards(base, n, &dir.join(format!("n{n}")));
            let files = assert_same_outputs(&single, &merged);
            (merged, files)
        })
        .collect()
}

/// Runs `base` in `n` shards (each into `dir/parts/K`) and merges them into `dir/merged`.
fn merge_shards(base: &[&str], n: usize, dir: &Path) -> PathBuf {
    let parts = shard_dirs(base, n, dir);
    let merged = dir.join("merged");
    let mut merge = vec!["merge".to_owned(), "--quiet".to_owned()];
    merge.extend(parts);
    merge.extend(["--out".to_owned(), merged.to_str().unwrap().to_owned()]);
    if base.contains(&"--no-plots") {
        merge.push("--no-plots".to_owned());
    }
    ok(icp_eval(&merge));
    merged
}

/// The timing fields dropped from a summary.json (as `tests/cli.rs` drops them).
fn summary_without_timing(text: &str) -> serde_json::Value {
    let mut json: serde_json::Value = serde_json::from_str(text).unwrap();
    for v in json["variants"].as_array_mut().unwrap() {
        assert!(v.as_object_mut().unwrap().remove("timing").is_some());
        if let Some(cycles) = v["cycles"].as_object_mut() {
            assert!(cycles.remove("lag_time_per_pair_us").is_some());
            assert!(cycles.remove("lag_search_time_per_pair_us").is_some());
        }
    }
    if let Some(search) = json["global_search"].as_object_mut() {
        assert!(search.remove("timing").is_some());
    }
    if let Some(sequence) = json["sequence"].as_array_mut() {
        for s in sequence {
            assert!(s.as_object_mut().unwrap().remove("time_ms").is_some());
        }
    }
    assert!(json
        .as_object_mut()
        .unwrap()
        .remove("preparation")
        .is_some());
    json
}

/// pairs.csv without its `time_us` column (the last).
fn pairs_without_timing(text: &str) -> String {
    assert!(text.lines().next().unwrap().ends_with(",time_us"));
    text.lines()
        .map(|l| l.rsplit_once(',').unwrap().0.to_owned() + "\n")
        .collect()
}

/// report.html without its timing section (the one part of the page that is not reproducible).
fn html_without_timing(text: &str) -> String {
    let start = text.find("<section id=\"timing\">");
    let end = start.and_then(|s| text[s..].find("</section>").map(|e| s + e));
    match (start, end) {
        (Some(s), Some(e)) => format!("{}{}", &text[..s], &text[e..]),
        _ => text.to_owned(),
    }
}

/// Every file of `single` but the manifest is in `merged` and equal, timing fields aside;
/// both directories list the same files. Returns how many files were compared.
fn assert_same_outputs(single: &Path, merged: &Path) -> usize {
    let names = |d: &Path| -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    assert_eq!(names(single), names(merged));
    let mut compared = 0;
    for name in names(single) {
        if single.join(&name).is_dir() {
            // evo/: the result zips, deterministic and free of timings.
            compared += assert_same_outputs(&single.join(&name), &merged.join(&name));
            continue;
        }
        let a = std::fs::read(single.join(&name)).unwrap();
        let b = std::fs::read(merged.join(&name)).unwrap();
        match name.as_str() {
            "pairs.csv" => assert_eq!(
                pairs_without_timing(&String::from_utf8(a).unwrap()),
                pairs_without_timing(&String::from_utf8(b).unwrap())
            ),
            "summary.json" => assert_eq!(
                summary_without_timing(&String::from_utf8(a).unwrap()),
                summary_without_timing(&String::from_utf8(b).unwrap())
            ),
            "report.html" => assert!(
                html_without_timing(&String::from_utf8(a).unwrap())
                    == html_without_timing(&String::from_utf8(b).unwrap()),
                "report.html differs beyond its timings"
            ),
            _ => assert!(a == b, "{name} differs"),
        }
        compared += 1;
    }
    compared
}

const RUN: [&str; 9] = [
    "run",
    "--dataset",
    "synthetic:paper",
    "--scans",
    "30",
    "--variants",
    "K_ICP,HD_ICP,PL_ICP",
    "--quiet",
    "--no-plots",
];

#[test]
fn run_shards_merge_to_the_single_run_with_identity_and_constant_velocity_starts() {
    for init in ["identity", "constant-velocity,identity"] {
        let mut base: Vec<&str> = RUN.to_vec();
        base.extend(["--init", init]);
        let dir = common::scratch_dir(&format!("shard_run_{}", init.len()));
        // 1 shard, 3, and 7 (more than the 3 variants a constant-velocity run is cut into).
        for (_, files) in merged_equal_single(&base, &dir, &[1, 3, 7]) {
            assert!(files >= 7, "{files} files compared");
        }
    }
}

/// Loops across lags: every shard registers the lag pairs of its own units, the merge judges
/// the loops, and the files (report.html, and the `inconsistent` statuses of pairs.csv) are
/// the single run's for every cut, shard counts whose edges split loops included.
#[test]
fn lag_shards_merge_to_the_single_run_with_its_inconsistent_flags() {
    for init in ["identity", "constant-velocity,identity"] {
        let mut base: Vec<&str> = RUN.to_vec();
        base.extend(["--dt", "2", "--init", init, "--lags", "3"]);
        let dir = common::scratch_dir(&format!("shard_lags_{}", init.len()));
        for (merged, files) in merged_equal_single(&base, &dir, &[2, 5]) {
            assert!(files >= 8, "{files} files compared");
            let pairs = std::fs::read_to_string(merged.join("pairs.csv")).unwrap();
            assert!(
                pairs.contains(",inconsistent,"),
                "no loop flagged: a weak test"
            );
            assert!(merged.join("cycles.csv").exists());
        }
    }
    // `--lags` beyond the run is refused before a shard runs.
    let dir = common::scratch_dir("shard_lags_too_long");
    let o = icp_eval(&args(
        &RUN,
        &[
            "--lags",
            "30",
            "--shard",
            "0/2",
            "--out",
            dir.to_str().unwrap(),
        ],
    ));
    assert_eq!(o.status.code(), Some(2));
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(said.contains("--lags 30: the run has 29 pairs"), "{said}");
}

/// A chain with a close start and a sequential one (`global,constant-velocity`) is cut by
/// methods, and the methods cut include gated twins (the surface metrics' close starts) and an
/// external estimate: every shard count merges to the single run. (A shard of the later
/// variants once ran them with the first variants' gated twins.)
#[test]
fn shards_cut_by_methods_keep_each_variants_gated_twin_and_the_external_estimates() {
    let dir = common::scratch_dir("shard_methods");
    let first = dir.join("first");
    ok(icp_eval(&args(&RUN, &["--out", first.to_str().unwrap()])));
    let truth = format!("TRUTH={}", first.join("reference.tum").display());
    let mut base: Vec<&str> = RUN.to_vec();
    base[6] = "HD_ICP,PL_ICP,HD_PL_ICP,GICP";
    base.extend(["--init", "global,constant-velocity", "--estimates", &truth]);
    for (merged, files) in merged_equal_single(&base, &dir, &[2, 3, 5]) {
        assert!(files >= 9, "{files} files compared");
        let summary = std::fs::read_to_string(merged.join("summary.json")).unwrap();
        assert!(summary.contains("\"start_gated\"") && summary.contains("\"TRUTH\""));
    }
}

/// The moving stage's placing chain is PL_ICP's own first results where PL_ICP is in the
/// shard and registered afresh where it is not: both give the single run's files.
#[test]
fn moving_returns_shards_place_as_the_single_run_with_or_without_pl_icp() {
    let base = [
        "run",
        "--dataset",
        "synthetic:rough",
        "--scans",
        "200",
        "--variants",
        "PL_ICP,GICP",
        "--reference-checks",
        "off",
        "--quiet",
        "--no-plots",
    ];
    let dir = common::scratch_dir("shard_moving");
    for (merged, files) in merged_equal_single(&base, &dir, &[2]) {
        assert!(files >= 7, "{files} files compared");
        let mut rows = csv::Reader::from_path(merged.join("pairs.csv")).unwrap();
        let header = rows.headers().unwrap().clone();
        let column = |name: &str| header.iter().position(|h| h == name).unwrap();
        let (variant, left_out) = (column("variant"), column("left_out_src"));
        let gicp_left_out: usize = rows
            .records()
            .map(|r| r.unwrap())
            .filter(|r| &r[variant] == "GICP")
            .map(|r| r[left_out].parse::<usize>().unwrap())
            .sum();
        assert!(gicp_left_out > 0, "nothing left out: a weak test");
    }
}

#[test]
fn figures_of_a_merged_run_equal_the_single_runs() {
    let base: Vec<&str> = RUN[..RUN.len() - 1].to_vec();
    let merged = merged_equal_single(&base, &common::scratch_dir("shard_plots"), &[3]);
    let (dir, files) = &merged[0];
    assert!(
        std::fs::read_dir(dir).unwrap().any(|e| e
            .unwrap()
            .path()
            .extension()
            .is_some_and(|x| x == "png")),
        "figures were drawn"
    );
    assert!(*files > 10, "{files} files compared");
}

#[test]
fn compare_with_a_sweep_shards_and_merges_to_the_single_run() {
    let base = [
        "compare",
        "--dataset",
        "synthetic:paper",
        "--scans",
        "30",
        "--variants",
        "H_ICP,HD_ICP",
        "--bootstrap",
        "200",
        "--sweep",
        "huber_c=1.5,3",
        "--quiet",
        "--no-plots",
    ];
    let dir = common::scratch_dir("shard_compare");
    for (merged, _) in merged_equal_single(&base, &dir, &[1, 3, 7]) {
        for f in ["compare.md", "compare.json", "sweep.md", "sweep.json"] {
            assert!(merged.join(f).is_file(), "{f} written");
        }
    }
}

#[test]
fn basin_shards_and_merges_to_the_single_run() {
    // 29 pairs, every 5th: 6 pairs, so 7 shards leave one part empty.
    let base = [
        "basin",
        "--dataset",
        "synthetic:paper",
        "--scans",
        "30",
        "--variants",
        "K_ICP,HD_ICP",
        "--perturbations",
        "3",
        "--pair-stride",
        "5",
        "--quiet",
        "--no-plots",
    ];
    let dir = common::scratch_dir("shard_basin");
    for (_, files) in merged_equal_single(&base, &dir, &[1, 3, 7]) {
        // basin.csv, .json, .md and report.html.
        assert_eq!(files, 5);
    }
}

/// The laptop form the README shows: `xargs -P` runs the shards at once.
#[test]
fn the_readme_laptop_form_runs_shards_in_parallel_and_merges() {
    let dir = common::scratch_dir("shard_xargs");
    let bin = env!("CARGO_BIN_EXE_icp-eval");
    let run = "run --dataset synthetic:paper --scans 30 --variants K_ICP,HD_ICP --quiet --no-plots";
    let script = format!(
        "set -e; cd {dir}; \
         seq 0 3 | xargs -P 4 -I{{}} {bin} {run} --shard {{}}/4 --out parts/{{}}; \
         {bin} merge parts/* --out merged --quiet --no-plots; \
         {bin} {run} --out single",
        dir = dir.display()
    );
    let mut sh = common::unsharded(Command::new("sh"));
    ok(sh.args(["-c", &script]).output().unwrap());
    assert_same_outputs(&dir.join("single"), &dir.join("merged"));
}

/// `n` shards of `base` into `dir/parts/K`, the part directories returned; each shard says
/// which it runs.
fn shard_dirs(base: &[&str], n: usize, dir: &Path) -> Vec<String> {
    (0..n)
        .map(|k| {
            let out = dir.join(format!("parts/{k}"));
            let shard = format!("{k}/{n}");
            let o = ok(icp_eval(&args(
                base,
                &["--shard", &shard, "--out", out.to_str().unwrap()],
            )));
            let said = String::from_utf8_lossy(&o.stderr);
            assert!(
                said.contains(&format!("shard {shard} (from --shard)")),
                "a shard says which it is: {said}"
            );
            out.to_str().unwrap().to_owned()
        })
        .collect()
}

fn merge_fails(parts: &[String], out: &Path) -> String {
    let mut a = vec!["merge".to_owned()];
    a.extend(parts.iter().cloned());
    a.extend(["--out".to_owned(), out.to_str().unwrap().to_owned()]);
    let o = icp_eval(&a);
    assert_eq!(o.status.code(), Some(2), "merge must refuse {parts:?}");
    assert!(!out.join("summary.json").exists(), "nothing merged");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn merge_refuses_a_missing_a_duplicate_and_a_foreign_part() {
    let dir = common::scratch_dir("shard_refuse");
    let base = &RUN[..];
    let parts = shard_dirs(base, 3, &dir.join("a"));
    let out = dir.join("merged");

    let said = merge_fails(&parts[..2], &out);
    assert!(
        said.contains("shard(s) [2] are not among the parts"),
        "{said}"
    );

    let twice = vec![parts[0].clone(), parts[1].clone(), parts[1].clone()];
    let said = merge_fails(&twice, &out);
    assert!(said.contains("shard 1 of 3 is given twice"), "{said}");

    // The same command on 20 scans: another plan.
    let mut other: Vec<&str> = base.to_vec();
    other[4] = "20";
    let foreign = shard_dirs(&other, 3, &dir.join("b"));
    let mixed = vec![parts[0].clone(), parts[1].clone(), foreign[2].clone()];
    let said = merge_fails(&mixed, &out);
    assert!(said.contains("is of another plan"), "{said}");

    // The same run cut in 2: another plan too (the shard count is part of it).
    let halves = shard_dirs(base, 2, &dir.join("c"));
    let said = merge_fails(&[parts[0].clone(), halves[1].clone()], &out);
    assert!(said.contains("is of another plan"), "{said}");

    // Not a part file at all.
    let junk = dir.join("junk/part-0-of-1.cbor");
    std::fs::create_dir_all(junk.parent().unwrap()).unwrap();
    std::fs::write(&junk, b"not cbor").unwrap();
    let said = merge_fails(&[junk.to_str().unwrap().to_owned()], &out);
    assert!(said.contains("not a part file"), "{said}");
}

/// A part's bytes with every timing set to 0 and without its command line (which says
/// `--threads` when given).
fn part_without_timing(path: &Path) -> Vec<u8> {
    let (_, mut part) = eval::shard::merge::read_part(path).unwrap();
    part.command_line.clear();
    for (_, results) in &mut part.slices {
        if let eval::shard::SliceResults::Runs { runs, lagged } = results {
            for runs in std::iter::once(runs).chain(lagged.as_mut().map(|l| &mut l.runs)) {
                runs.per_variant
                    .iter_mut()
                    .flatten()
                    .for_each(|r| r.time_us = r.time_us.map(|_| 0.0));
                runs.searches.iter_mut().for_each(|s| s.time_us = 0.0);
                runs.prepare_us.iter_mut().for_each(|t| *t = 0.0);
            }
        }
    }
    part.to_bytes().unwrap()
}

#[test]
fn re_running_a_shard_rewrites_the_same_part() {
    let dir = common::scratch_dir("shard_again");
    // Variants without a detector of moving returns: the pair cut (PL_ICP's detector gives
    // each shard whole variants).
    let mut base: Vec<&str> = RUN
        .iter()
        .map(|&a| {
            if a == "K_ICP,HD_ICP,PL_ICP" {
                "K_ICP,HD_ICP"
            } else {
                a
            }
        })
        .collect();
    base.extend(["--init", "global", "--lags", "2"]);
    let part_dir = &shard_dirs(&base, 3, &dir)[1];
    let file = Path::new(part_dir).join("part-1-of-3.cbor");
    let first = part_without_timing(&file);
    ok(icp_eval(&args(
        &base,
        &["--shard", "1/3", "--out", part_dir, "--threads", "1"],
    )));
    assert!(first == part_without_timing(&file), "the part changed");
    let (_, part) = eval::shard::merge::read_part(&file).unwrap();
    assert!(part.command_line.iter().any(|a| a == "--threads"));
    assert_eq!(part.shard, Shard { index: 1, count: 3 });
    let (runs, lagged) = match &part.slices[0].1 {
        eval::shard::SliceResults::Runs { runs, lagged } => (runs, lagged.as_ref().unwrap()),
        other => panic!("{other:?}"),
    };
    let units = &part.slices[0].0.units;
    assert_eq!(runs.searches.len(), units.len(), "searches kept");
    // The lag pairs whose first consecutive pair is in the slice, and only those.
    assert_eq!(lagged.pairs.len(), units.len());
    assert!(lagged
        .pairs
        .iter()
        .all(|p| units.contains(&p.first) && p.lag == 2));
    assert_eq!(lagged.runs.searches.len(), units.len());
}

#[test]
fn a_slurm_array_task_shards_a_plain_run_and_says_so() {
    let dir = common::scratch_dir("shard_slurm");
    let out = dir.join("task");
    let o = ok(common::icp_eval_command()
        .args(RUN)
        .args(["--out", out.to_str().unwrap()])
        .env("SLURM_ARRAY_TASK_ID", "5")
        .env("SLURM_ARRAY_TASK_MIN", "4")
        .env("SLURM_ARRAY_TASK_COUNT", "4")
        .output()
        .unwrap());
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(
        said.contains("shard 1/4 (from SLURM_ARRAY_TASK_ID=5 − SLURM_ARRAY_TASK_MIN=4 of SLURM_ARRAY_TASK_COUNT=4)")
            && said.contains("--no-shard runs everything"),
        "{said}"
    );
    assert!(out.join("part-1-of-4.cbor").is_file());
    assert!(!out.join("summary.json").exists());
    // --no-shard: the whole run, in the same job.
    let whole = dir.join("whole");
    ok(common::icp_eval_command()
        .args(RUN)
        .args(["--no-shard", "--out", whole.to_str().unwrap()])
        .env("SLURM_ARRAY_TASK_ID", "5")
        .env("SLURM_ARRAY_TASK_MIN", "4")
        .env("SLURM_ARRAY_TASK_COUNT", "4")
        .output()
        .unwrap());
    assert!(whole.join("summary.json").is_file());
    // A bad variable: exit 2 naming it.
    let o = common::icp_eval_command()
        .args(RUN)
        .args(["--out", dir.join("bad").to_str().unwrap()])
        .env("JOB_COMPLETION_INDEX", "two")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr)
        .contains("JOB_COMPLETION_INDEX=\"two\" is not a whole number"));
}

fn env(vars: &[(&str, &str)]) -> BTreeMap<String, String> {
    vars.iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}

/// A Slurm array task's variables.
fn slurm(id: &str, min: &str, count: &str) -> BTreeMap<String, String> {
    env(&[
        ("SLURM_ARRAY_TASK_ID", id),
        ("SLURM_ARRAY_TASK_MIN", min),
        ("SLURM_ARRAY_TASK_COUNT", count),
    ])
}

fn shard(index: usize, count: usize) -> Shard {
    Shard { index, count }
}

#[test]
fn the_shard_comes_from_the_option_slurm_or_kubernetes_and_they_must_agree() {
    let none = env(&[]);
    assert_eq!(resolve(None, None, &none), Ok(None));
    assert_eq!(
        resolve(Some(shard(2, 4)), None, &none),
        Ok(Some((shard(2, 4), ShardOrigin::Option)))
    );
    assert_eq!("2/4".parse::<Shard>(), Ok(shard(2, 4)));
    assert!(matches!(
        "4/4".parse::<Shard>(),
        Err(ShardError::OutOfRange { .. })
    ));
    assert!(matches!(
        "0/0".parse::<Shard>(),
        Err(ShardError::NoShards { .. })
    ));
    for bad in ["2", "a/4", "2/b", "-1/4", "1/2/3", ""] {
        assert!(
            matches!(bad.parse::<Shard>(), Err(ShardError::Syntax(_))),
            "{bad}"
        );
    }

    // Slurm: the index counts from SLURM_ARRAY_TASK_MIN.
    let task = slurm("7", "5", "3");
    let got = resolve(None, None, &task).unwrap().unwrap();
    assert_eq!(got.0, shard(2, 3));
    assert_eq!(
        got.1,
        ShardOrigin::Slurm {
            id: 7,
            min: 5,
            count: 3
        }
    );
    assert_eq!(
        resolve(Some(shard(2, 3)), Some(3), &task)
            .unwrap()
            .unwrap()
            .0,
        shard(2, 3)
    );
    assert!(matches!(
        resolve(Some(shard(1, 3)), None, &task),
        Err(ShardError::Disagree { .. })
    ));
    assert!(matches!(
        resolve(None, Some(4), &task),
        Err(ShardError::Disagree { .. })
    ));
    // A stepped or sparse array (--array=5-9:2 has ids 5, 7, 9 and count 3): id 9 is beyond.
    let sparse = slurm("9", "5", "3");
    assert!(matches!(
        resolve(None, None, &sparse),
        Err(ShardError::OutOfRange {
            index: 4,
            count: 3,
            ..
        })
    ));
    let below = slurm("1", "2", "3");
    assert!(matches!(
        resolve(None, None, &below),
        Err(ShardError::OutOfRange { .. })
    ));
    let alone = env(&[("SLURM_ARRAY_TASK_ID", "1")]);
    assert!(matches!(
        resolve(None, None, &alone),
        Err(ShardError::Incomplete { .. })
    ));
    let zero = slurm("0", "0", "0");
    assert!(matches!(
        resolve(None, None, &zero),
        Err(ShardError::NoShards { .. })
    ));
    let text = slurm("1", "0", "4x");
    assert_eq!(
        resolve(None, None, &text),
        Err(ShardError::NotANumber {
            variable: "SLURM_ARRAY_TASK_COUNT",
            value: "4x".to_owned()
        })
    );

    // Kubernetes: the completion index, with --shards.
    let k8s = env(&[("JOB_COMPLETION_INDEX", "3")]);
    assert_eq!(resolve(None, None, &k8s), Err(ShardError::NeedsShards(3)));
    assert_eq!(
        resolve(None, Some(5), &k8s).unwrap().unwrap(),
        (
            shard(3, 5),
            ShardOrigin::Kubernetes {
                index: 3,
                shards: 5
            }
        )
    );
    assert!(matches!(
        resolve(None, Some(3), &k8s),
        Err(ShardError::OutOfRange { .. })
    ));
    assert!(matches!(
        resolve(None, Some(0), &k8s),
        Err(ShardError::NoShards { .. })
    ));
    assert_eq!(
        resolve(None, Some(4), &none),
        Err(ShardError::ShardsWithoutIndex(4))
    );
    // Both schedulers' variables, naming different shards.
    let both = env(&[
        ("SLURM_ARRAY_TASK_ID", "1"),
        ("SLURM_ARRAY_TASK_MIN", "0"),
        ("SLURM_ARRAY_TASK_COUNT", "4"),
        ("JOB_COMPLETION_INDEX", "2"),
    ]);
    assert!(matches!(
        resolve(None, Some(4), &both),
        Err(ShardError::Disagree { .. })
    ));
    let agree = env(&[
        ("SLURM_ARRAY_TASK_ID", "2"),
        ("SLURM_ARRAY_TASK_MIN", "0"),
        ("SLURM_ARRAY_TASK_COUNT", "4"),
        ("JOB_COMPLETION_INDEX", "2"),
    ]);
    assert_eq!(
        resolve(None, Some(4), &agree).unwrap().unwrap().0,
        shard(2, 4)
    );
}

/// `--sequence`: the smoothed estimators are made at the merge from every shard's
/// registrations (consecutive and across lags), and equal the single run's, sequence.csv
/// included.
#[test]
fn sequence_shards_smooth_at_the_merge_as_the_single_run() {
    let base = [
        "run",
        "--dataset",
        "synthetic:paper",
        "--scans",
        "30",
        "--variants",
        "PL_ICP,GICP",
        "--lags",
        "3",
        "--sequence",
        "batch,causal",
        "--quiet",
        "--no-plots",
    ];
    let dir = common::scratch_dir("shard_sequence");
    for (merged, files) in merged_equal_single(&base, &dir, &[2, 3]) {
        assert!(files >= 8, "{files} files compared");
        let sequence = std::fs::read_to_string(merged.join("sequence.csv")).unwrap();
        // 30 scans for each of PL_ICP+batch, PL_ICP+causal, GICP+batch, GICP+causal.
        assert_eq!(sequence.lines().count(), 1 + 4 * 30);
        // The causal estimators' live sentences, four per scan, written at the merge too.
        for v in ["PL_ICP", "GICP"] {
            let nmea = std::fs::read_to_string(merged.join(format!("{v}+causal.nmea"))).unwrap();
            assert_eq!(nmea.split_terminator("\r\n").count(), 4 * 30);
        }
        let pairs = std::fs::read_to_string(merged.join("pairs.csv")).unwrap();
        assert_eq!(
            pairs
                .lines()
                .filter(|l| l.starts_with("GICP+causal,"))
                .count(),
            29
        );
    }
}

/// `--sequence deskew`: the pairs are registered again on the deskewed scans at the merge,
/// without the returns each shard's moving-returns stage left out of both scans (carried in
/// the part files), and the result equals the single run's.
#[test]
fn deskew_shards_register_again_at_the_merge_as_the_single_run() {
    let base = [
        "run",
        "--dataset",
        "synthetic:rough?scans=30",
        "--variants",
        "PL_ICP,GICP",
        "--lags",
        "2",
        "--sequence",
        "batch,deskew",
        "--quiet",
        "--no-plots",
    ];
    let dir = common::scratch_dir("shard_deskew");
    for (merged, files) in merged_equal_single(&base, &dir, &[2]) {
        assert!(files >= 8, "{files} files compared");
        let sequence = std::fs::read_to_string(merged.join("sequence.csv")).unwrap();
        // 30 scans for each of PL_ICP+batch, PL_ICP+deskew, GICP+batch, GICP+deskew.
        assert_eq!(sequence.lines().count(), 1 + 4 * 30);
        assert!(sequence.lines().any(|l| l.starts_with("GICP+deskew,")));
    }
}
