"""run(): the harness's run with weightings written in Python."""

import csv
import json

import numpy as np
import pytest

import icp_bench
from conftest import REPO, SMALL

REPO_TOLERANCE = REPO / "reports" / "baseline" / "tolerance.json"


def inverse_range(pairs):
    """IR_ICP's scheme (w = 1 / (r0 + mean range), r0 = 1 m), vectorised."""
    return 1.0 / (1.0 + 0.5 * (pairs["src_range_m"] + pairs["dst_range_m"]))


def rows_of(out, variant):
    with open(out / "pairs.csv", newline="") as f:
        return [r for r in csv.DictReader(f) if r["variant"] == variant]


def test_a_python_weighting_equals_the_same_scheme_in_rust(tmp_path):
    out = tmp_path / "run"
    summary = icp_bench.run(SMALL, ["IR_ICP"], {"PY_IR": ("H_ICP", inverse_range)}, out=out,
                            plots=False)
    assert [v["name"] for v in summary["variants"]] == ["IR_ICP", "PY_IR"]
    assert summary == json.loads((out / "summary.json").read_text())
    spec = summary["config"]["variants"][1]
    assert spec["name"] == "PY_IR"
    assert spec["weighting"] == {"kind": "python:inverse_range", "base_variant": "H_ICP"}
    rust, python = rows_of(out, "IR_ICP"), rows_of(out, "PY_IR")
    assert len(rust) == len(python) == 7
    skip = {"variant", "time_us"}
    for a, b in zip(rust, python):
        assert {k: v for k, v in a.items() if k not in skip} == {
            k: v for k, v in b.items() if k not in skip
        }
    assert (out / "trajectory_PY_IR.tum").exists()


def test_the_function_gets_the_pairs(tmp_path):
    seen = []

    def record(pairs):
        seen.append(pairs)
        return np.ones_like(pairs["src_range_m"])

    icp_bench.run(SMALL, [], {"REC": ("H_ICP", record)}, out=tmp_path / "run", plots=False,
                  threads=1, global_check="off")
    first = seen[0]
    names = {"src_range_m", "dst_range_m", "src_bearing_rad", "dst_bearing_rad", "src_x_m",
             "src_y_m", "dst_x_m", "dst_y_m", "normal_x", "normal_y", "src_sigma_r_m",
             "dst_sigma_r_m", "src_sigma_alpha_rad", "dst_sigma_alpha_rad"}
    assert names <= set(first)
    n = len(first["src_range_m"])
    for name in names:
        assert first[name].shape == (n,) and first[name].dtype == np.float64
    assert first["iteration"] == 0 and first["rotation_rad"] == 0.0
    # Identity start: the moved source points are the source returns (eq. 10).
    assert np.allclose(first["src_x_m"], first["src_range_m"] * np.cos(first["src_bearing_rad"]))
    assert np.allclose(first["dst_y_m"], first["dst_range_m"] * np.sin(first["dst_bearing_rad"]))
    unit = np.hypot(first["normal_x"], first["normal_y"])
    assert np.allclose(unit[~np.isnan(unit)], 1.0)
    assert any(p["iteration"] > 0 and p["rotation_rad"] != 0.0 for p in seen)


def sigmas_seen(tmp_path, name, **options):
    """The σ fields and ranges of every dict a recording weighting gets in a run."""
    seen = []

    def record(pairs):
        seen.append({k: np.array(pairs[k]) for k in (
            "src_range_m", "dst_range_m", "src_sigma_r_m", "dst_sigma_r_m",
            "src_sigma_alpha_rad", "dst_sigma_alpha_rad")})
        return np.ones_like(pairs["src_range_m"])

    icp_bench.run(SMALL, [], {"REC": ("H_ICP", record)}, out=tmp_path / name, plots=False,
                  threads=1, global_check="off", **options)
    assert seen
    return seen


def test_the_pairs_carry_each_returns_sensor_sigma(tmp_path, small):
    """Issue 33: users hard-coded 0.004258 * r. Each return's σ_r (m) and σ_α (rad) come
    from the run's sensor model: sigma_r_const_m + sigma_r_per_m * range, and sigma_alpha_rad."""
    for name, options, model in [
        ("dataset", {}, small.sensor),
        ("overridden", {"sensor": {"sigma_r_const_m": 0.01, "sigma_alpha_deg": 0.25}},
         dict(small.sensor, sigma_r_const_m=0.01, sigma_alpha_rad=np.radians(0.25))),
    ]:
        for p in sigmas_seen(tmp_path, name, **options):
            for end in ("src", "dst"):
                sigma_r = model["sigma_r_const_m"] + model["sigma_r_per_m"] * p[f"{end}_range_m"]
                assert np.allclose(p[f"{end}_sigma_r_m"], sigma_r, rtol=1e-15, atol=0), name
                assert p[f"{end}_sigma_alpha_rad"].shape == p[f"{end}_range_m"].shape
                assert np.allclose(p[f"{end}_sigma_alpha_rad"], model["sigma_alpha_rad"],
                                   rtol=1e-15, atol=0), name


def test_results_do_not_depend_on_the_thread_count(tmp_path):
    one = icp_bench.run(SMALL, [], {"PY_IR": ("H_ICP", inverse_range)}, out=tmp_path / "a",
                        plots=False, threads=1)
    two = icp_bench.run(SMALL, [], {"PY_IR": ("H_ICP", inverse_range)}, out=tmp_path / "b",
                        plots=False, threads=2)
    strip = lambda s: {k: v for k, v in s.items() if k not in ("variants", "preparation",
                                                               "global_search")}
    assert strip(one) == strip(two)
    for a, b in zip(rows_of(tmp_path / "a", "PY_IR"), rows_of(tmp_path / "b", "PY_IR")):
        assert (a["tx_m"], a["ty_m"], a["theta_deg"]) == (b["tx_m"], b["ty_m"], b["theta_deg"])


def short(pairs):
    return np.ones(len(pairs["src_range_m"]) - 1)


def nan_at_iteration_2(pairs):
    w = np.ones_like(pairs["src_range_m"])
    if pairs["iteration"] == 2:
        w[7] = np.nan
    return w


def negative(pairs):
    w = np.ones_like(pairs["src_range_m"])
    w[0] = -0.5
    return w


def raises(pairs):
    raise ZeroDivisionError("no weights today")


def matrix(pairs):
    return np.ones((len(pairs["src_range_m"]), 2))


@pytest.mark.parametrize(
    "fn, message",
    [
        (short, r"iteration 0: \d+ weights returned for \d+ pairs"),
        (nan_at_iteration_2, "iteration 2: weight 7 is NaN: weights must be finite and >= 0"),
        (negative, "iteration 0: weight 0 is -0.5: weights must be finite and >= 0"),
        (raises, "iteration 0: raises: ZeroDivisionError: no weights today"),
        (matrix, "iteration 0: matrix: TypeError: the weights must be a 1-D array of numbers"),
    ],
)
def test_a_bad_weighting_names_the_variant_and_the_iteration(tmp_path, fn, message):
    with pytest.raises(icp_bench.WeightingError, match=message) as e:
        icp_bench.run(SMALL, ["H_ICP"], {"MINE": ("H_ICP", fn)}, out=tmp_path / "run",
                      plots=False)
    assert isinstance(e.value, ValueError)
    assert str(e.value).startswith("variant MINE, pair 0 (scans 0 → 1): the pair weighting failed")
    assert not (tmp_path / "run" / "summary.json").exists()


@pytest.mark.parametrize(
    "kwargs, error, message",
    [
        (dict(variants=["X_ICP"]), icp_bench.ConfigError, 'unknown variant "X_ICP"'),
        (dict(weightings={"A": ("X_ICP", inverse_range)}), icp_bench.ConfigError,
         'unknown variant "X_ICP"'),
        (dict(weightings={"A": inverse_range}), icp_bench.ConfigError,
         r"weighting A: expected \(BASE_VARIANT, fn\)"),
        (dict(weightings={"A": ("H_ICP", 3)}), icp_bench.ConfigError, "3 is not callable"),
        (dict(weightings={"H_ICP": ("H_ICP", inverse_range)}), icp_bench.ConfigError,
         "two variants are named H_ICP"),
        (dict(weightings={"a b": ("H_ICP", inverse_range)}), icp_bench.ConfigError,
         "only letters, digits"),
        (dict(huber_c=-1.0), icp_bench.ConfigError, 'robust "median_scaled": c = -1'),
        (dict(init="sideways"), icp_bench.ConfigError, "option init=sideways"),
        (dict(reference_checks="maybe"), icp_bench.ConfigError, "option reference_checks"),
        (dict(covariance="guess"), icp_bench.ConfigError, "unknown mode"),
        (dict(sensor={"sigma_alpha_deg": -1}), icp_bench.ConfigError, "option sensor"),
        (dict(threads=0), icp_bench.ConfigError, "option threads: at least 1"),
        (dict(lags=0), icp_bench.ConfigError, "--lags 0: a lag is at least 1"),
        (dict(lags=99), icp_bench.ConfigError, "--lags 99: the run has 7 pairs"),
        (dict(sequence=["sideways"]), icp_bench.ConfigError,
         'option sequence: unknown mode "sideways"'),
        (dict(sequence=3), icp_bench.ConfigError, "option sequence: expected a list of modes"),
        (dict(motion_prior="wobbly"), icp_bench.ConfigError, "option motion_prior"),
        (dict(colour="red"), icp_bench.ConfigError, 'unknown option "colour"'),
        (dict(variants=[]), icp_bench.ConfigError, "no variant to run"),
    ],
)
def test_bad_run_options(tmp_path, kwargs, error, message):
    kwargs.setdefault("variants", ["H_ICP"])
    with pytest.raises(error, match=message):
        icp_bench.run(SMALL, out=tmp_path / "run", plots=False, **kwargs)


def test_run_options_reach_the_harness(tmp_path):
    s = icp_bench.run(SMALL, ["HD_ICP"], out=tmp_path / "run", plots=False, huber_c=3.0,
                      sensor={"sigma_alpha_deg": 0.25}, reference_offset=0, init="identity",
                      global_check="off", covariance="off")
    spec = s["config"]["variants"][0]
    assert spec["robust"]["c"] == 3.0
    assert spec["sensor"]["sigma_alpha_rad"] == pytest.approx(np.radians(0.25), rel=1e-15)
    # A directory of other files than a run's is refused, as by the command line, unless forced.
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("x")
    with pytest.raises(icp_bench.OutputError, match="notes.txt") as e:
        icp_bench.run(SMALL, ["HD_ICP"], out=tmp_path / "mine", plots=False)
    assert isinstance(e.value, OSError)
    icp_bench.run(SMALL, ["HD_ICP"], out=tmp_path / "mine", plots=False, force=True)
    assert (tmp_path / "mine" / "notes.txt").exists()


def test_lags_write_the_loops_the_command_line_writes(tmp_path, icp_eval):
    import subprocess

    py = tmp_path / "py"
    s = icp_bench.run(SMALL, ["HD_ICP", "PL_ICP"], out=py, plots=False, lags=2)
    assert s["config"]["lags"] == 2
    # 8 scans: 7 consecutive pairs, 6 loops across lag 2 per variant.
    assert [v["cycles"]["triangles"] for v in s["variants"]] == [6, 6]
    cli = tmp_path / "cli"
    subprocess.run([icp_eval, "run", "--dataset", SMALL, "--variants", "HD_ICP,PL_ICP",
                    "--lags", "2", "--no-plots", "--quiet", "--out", cli],
                   check=True, capture_output=True)
    # cycles.csv holds no timing: byte for byte.
    assert (py / "cycles.csv").read_bytes() == (cli / "cycles.csv").read_bytes()
    assert len((py / "cycles.csv").read_text().splitlines()) == 1 + 2 * 6
    skip = {"time_us"}
    with open(py / "pairs.csv", newline="") as a, open(cli / "pairs.csv", newline="") as b:
        for x, y in zip(csv.DictReader(a), csv.DictReader(b), strict=True):
            assert {k: v for k, v in x.items() if k not in skip} == {
                k: v for k, v in y.items() if k not in skip
            }
    # Without the option, a run registers consecutive pairs only.
    plain = icp_bench.run(SMALL, ["HD_ICP"], out=tmp_path / "plain", plots=False)
    assert plain["config"]["lags"] == 1
    assert not (tmp_path / "plain" / "cycles.csv").exists()


def test_sequence_gives_the_fused_figures_the_command_line_gives(tmp_path, icp_eval):
    import subprocess

    py = tmp_path / "py"
    s = icp_bench.run(SMALL, ["HD_ICP", "PL_ICP"], out=py, plots=False, lags=2,
                      sequence=["batch", "causal"])
    # Point-to-point HD_ICP has no covariance to smooth with: PL_ICP alone is smoothed.
    assert [v["name"] for v in s["variants"]] == [
        "HD_ICP", "PL_ICP", "PL_ICP+batch", "PL_ICP+causal"]
    assert [q["method"] for q in s["sequence"]] == ["PL_ICP+batch", "PL_ICP+causal"]
    cli = tmp_path / "cli"
    subprocess.run([icp_eval, "run", "--dataset", SMALL, "--variants", "HD_ICP,PL_ICP",
                    "--lags", "2", "--sequence", "batch,causal", "--no-plots", "--quiet",
                    "--out", cli], check=True, capture_output=True)
    # The fused figures hold no timing: byte for byte.
    for name in ["sequence.csv", "PL_ICP+causal.nmea"]:
        assert (py / name).read_bytes() == (cli / name).read_bytes(), name
    assert len((py / "sequence.csv").read_text().splitlines()) == 1 + 2 * 8
    with open(cli / "summary.json") as f:
        summary = json.load(f)
    # Each estimator's smoothing time (time_ms) is a timing: the rest equal.
    def untimed(sequence):
        return [{k: v for k, v in q.items() if k != "time_ms"} for q in sequence]

    assert all(q["time_ms"] >= 0 for q in s["sequence"] + summary["sequence"])
    assert untimed(s["sequence"]) == untimed(summary["sequence"])
    for ours, theirs in zip(s["variants"][2:], summary["variants"][2:], strict=True):
        assert ours["all_pairs"] == theirs["all_pairs"]
        assert ours["consistency"] == theirs["consistency"]
    with open(py / "pairs.csv", newline="") as a, open(cli / "pairs.csv", newline="") as b:
        fused = [
            [{k: v for k, v in row.items() if k != "time_us"}
             for row in csv.DictReader(f) if "+" in row["variant"]]
            for f in (a, b)
        ]
    assert len(fused[0]) == 2 * 7 and fused[0] == fused[1]
    # The command line's comma-separated text is taken too.
    again = icp_bench.run(SMALL, ["PL_ICP"], out=tmp_path / "text", plots=False, lags=2,
                          sequence="batch,causal")
    assert again["sequence"][0]["qc"] == s["sequence"][0]["qc"]


def test_the_motion_prior_is_the_command_lines(tmp_path, icp_eval):
    import subprocess

    py = tmp_path / "py"
    s = icp_bench.run(SMALL, ["PL_ICP"], out=py, plots=False, lags=2, sequence="batch,causal",
                      motion_prior="white_jerk")
    assert [q["motion_prior"] for q in s["sequence"]] == ["white_jerk"] * 2
    cli = tmp_path / "cli"
    subprocess.run([icp_eval, "run", "--dataset", SMALL, "--variants", "PL_ICP", "--lags", "2",
                    "--sequence", "batch,causal", "--motion-prior", "white_jerk", "--no-plots",
                    "--quiet", "--out", cli], check=True, capture_output=True)
    for name in ["sequence.csv", "PL_ICP+causal.nmea"]:
        assert (py / name).read_bytes() == (cli / name).read_bytes(), name
    # The default prior is another model: another Qc (in other units) and other figures.
    default = icp_bench.run(SMALL, ["PL_ICP"], out=tmp_path / "default", plots=False, lags=2,
                            sequence="batch,causal")
    assert default["sequence"][0]["motion_prior"] == "white_acceleration"
    assert default["sequence"][0]["qc"] != s["sequence"][0]["qc"]
    assert (tmp_path / "default" / "sequence.csv").read_bytes() != (py / "sequence.csv").read_bytes()


def test_a_python_variant_enters_compare_and_the_gate(tmp_path, icp_eval):
    import subprocess

    out = tmp_path / "cmp"
    result = icp_bench.compare(SMALL, ["H_ICP"], {"PY_IR": ("H_ICP", inverse_range)}, out=out,
                               plots=False, bootstrap=500, bootstrap_seed=1)
    assert result == json.loads((out / "compare.json").read_text())
    assert result["options"] == {"resamples": 500, "seed": 1}
    assert any({c["a"], c["b"]} == {"H_ICP", "PY_IR"} for c in result["comparisons"])
    assert "PY_IR" in (out / "compare.md").read_text()
    # The gate takes its summary like any other: the same run passes against itself, and a
    # baseline where PY_IR registered one more pair is a regression of PY_IR.
    summary = out / "summary.json"
    ok = subprocess.run([icp_eval, "gate", "--baseline", summary, "--current", summary,
                         "--tolerance", REPO_TOLERANCE], capture_output=True, text=True)
    assert ok.returncode == 0, ok.stdout + ok.stderr
    better = json.loads(summary.read_text())
    for v in better["variants"]:
        if v["name"] == "PY_IR":
            v["pairs_ok"] += 1
    baseline = tmp_path / "baseline.json"
    baseline.write_text(json.dumps(better))
    worse = subprocess.run([icp_eval, "gate", "--baseline", baseline, "--current", summary,
                            "--tolerance", REPO_TOLERANCE], capture_output=True, text=True)
    assert worse.returncode == 1, worse.stdout + worse.stderr
    assert "PY_IR" in worse.stdout


def test_the_gil_is_released_while_a_run_runs(tmp_path):
    """Another Python thread runs during run(). With a long switch interval the interpreter
    does not hand the GIL over on its own, so the counting thread advances only while run()
    has released it."""
    import sys
    import threading

    ticks, stop = [0], threading.Event()

    def count():
        while not stop.is_set():
            ticks[0] += 1

    interval = sys.getswitchinterval()
    sys.setswitchinterval(0.5)
    counter = threading.Thread(target=count)
    try:
        counter.start()
        before = ticks[0]
        icp_bench.run(SMALL, ["HD_ICP", "HD_GICP"], out=tmp_path / "run", plots=False,
                      threads=1)
        during = ticks[0] - before
    finally:
        stop.set()
        counter.join()
        sys.setswitchinterval(interval)
    assert during > 1000, during
