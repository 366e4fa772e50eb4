"""register(), load(), motion(), variants() and kinds() against the Rust CLI."""

import csv
import math
import subprocess

import numpy as np
import pytest

import icp_bench
from conftest import SMALL


def test_variants_and_kinds_are_the_registry(icp_eval):
    listing = subprocess.run(
        [icp_eval, "list"], check=True, capture_output=True, text=True
    ).stdout
    names = icp_bench.variants()
    assert names[:4] == ["K_ICP", "H_ICP", "HM_ICP", "HD_ICP"]
    kinds = icp_bench.kinds()
    assert [v["name"] for v in kinds["variants"]] == names
    for name in names:
        assert f"  {name}  " in listing or f"  {name} " in listing
    for family in kinds["families"]:
        assert f"\n{family['name']}: {family['summary']}\n" in listing
        for kind in family["kinds"]:
            assert f"  {kind['name']}: {kind['summary']}\n" in listing
            for p in kind["parameters"]:
                assert f"      {p['name']} ({p['type_name']}, default " in listing
    assert {s["name"] for s in kinds["sections"]} == {"surfaces", "sensor", "termination"}


def test_load_gives_arrays_of_the_dataset(small):
    assert len(small) == 8 and len(small.scans) == 8
    for scan in small.scans:
        assert scan.dtype == np.float64 and scan.ndim == 2 and scan.shape[1] == 2
        assert (scan[:, 0] > 0).all()
    assert small.reference.shape == (8, 3)
    assert small.reference_kind.startswith("ground truth")
    assert small.timestamps.shape == (8,)
    assert np.all(np.diff(small.timestamps) > 0)
    assert set(small.sensor) == {"sigma_r_const_m", "sigma_r_per_m", "sigma_alpha_rad"}
    assert isinstance(small.warnings, list)
    assert small.bearing_sense in ("counter_clockwise", "clockwise")


def read_pairs(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def opt(text):
    return None if text == "" else float(text)


@pytest.mark.parametrize("variant", ["K_ICP", "HD_ICP", "HD_GICP", "PL_ICP"])
def test_register_is_bit_equal_to_icp_eval_run(small, icp_eval, tmp_path, variant):
    out = tmp_path / "run"
    subprocess.run(
        [icp_eval, "run", "--dataset", SMALL, "--variants", variant, "--out", out,
         "--no-plots", "--quiet"],
        check=True,
        capture_output=True,
    )
    rows = read_pairs(out / "pairs.csv")
    assert len(rows) == len(small) - 1
    scans = small.scans
    for row in rows:
        k, k1 = int(row["source"]), int(row["reference"])
        r = icp_bench.register(scans[k], scans[k1], variant, sensor=small.sensor)
        tx, ty, _ = r.t_ref_src
        assert (tx, ty, r.theta_deg) == (
            float(row["tx_m"]), float(row["ty_m"]), float(row["theta_deg"])
        ), row["pair"]
        assert r.iterations == int(row["iterations"])
        assert r.n_pairs == int(row["n_pairs"])
        assert r.n_unusable == int(row["n_unusable"])
        assert r.weight_sum == float(row["weight_sum"])
        assert r.mean_residual_m == float(row["mean_residual_m"])
        assert r.overlap == float(row["overlap"])
        assert r.cond_ratio == opt(row["cond_ratio"])
        assert r.converged == (row["converged"] == "true")
        cov = r.covariance
        columns = ["cov_xx_m2", "cov_xy_m2", "cov_xt_m_rad", "cov_yy_m2", "cov_yt_m_rad",
                   "cov_tt_rad2"]
        if cov is None:
            assert all(row[c] == "" for c in columns)
        else:
            entries = [cov[0, 0], cov[0, 1], cov[0, 2], cov[1, 1], cov[1, 2], cov[2, 2]]
            assert entries == [float(row[c]) for c in columns]
        # The run's status also weighs a global check, which register() does not make.
        if row["status"] in ("ok", "degenerate", "no_overlap"):
            assert r.status == row["status"]


def test_register_recovers_a_known_motion():
    """Known truth: three walls seen again after a known motion (the scene of icp-core's
    crate example) are registered back."""
    def wall(i):
        s = i * 0.25
        return [(10.0, -5.0 + s), (-3.0 + s, 8.0), (-3.0 + s * 0.5, -7.0 - s * 0.3)][i % 3]

    pts = np.array([wall(i) for i in range(120)])
    t = (-0.30, 0.02, math.radians(0.5))
    c, s = math.cos(t[2]), math.sin(t[2])
    # Reference-frame points: p_ref = R p_src + t.
    moved = pts @ np.array([[c, s], [-s, c]]) + np.array(t[:2])
    polar = lambda p: np.column_stack([np.hypot(p[:, 0], p[:, 1]), np.arctan2(p[:, 1], p[:, 0])])
    r = icp_bench.register(polar(pts), polar(moved), "HD_ICP")
    assert abs(r.t_ref_src[0] - t[0]) < 1e-6
    assert abs(r.t_ref_src[1] - t[1]) < 1e-6
    assert abs(r.t_ref_src[2] - t[2]) < 1e-7
    assert r.converged


def test_register_accepts_a_spec_dict_and_a_start(small):
    spec = {"name": "T_ICP", "weighting": "directional",
            "robust": {"kind": "median_scaled", "kernel": "tukey", "c": 4.685}}
    r = icp_bench.register(small.scans[0], small.scans[1], spec, init=(-1.0, 0.0, 0.0))
    assert r.variant == "T_ICP"
    default = icp_bench.register(small.scans[0], small.scans[1])
    assert default.variant == "HD_GICP"
    assert default.covariance.shape == (3, 3)
    assert np.allclose(default.covariance, default.covariance.T)


def test_motion_matches_the_closed_form():
    m = icp_bench.motion((-1.2, 0.05, math.radians(1.5)), 0.5, 350.0)
    assert m["sog_mps"] == math.hypot(-1.2, 0.05) / 0.5
    assert m["dcog_deg"] == pytest.approx(1.5, abs=1e-12)
    assert m["rot_dps"] == pytest.approx(3.0, abs=1e-12)
    assert m["hdg_deg"] == pytest.approx(351.5, abs=1e-12)
    assert m["sog_sigma_mps"] is None
    cw = icp_bench.motion((-1.2, 0.05, math.radians(1.5)), 0.5, 350.0, bearing_sense="clockwise")
    assert cw["dcog_deg"] == pytest.approx(-1.5, abs=1e-12)
    cov = np.diag([0.01**2, 0.02**2, math.radians(0.1) ** 2])
    s = icp_bench.motion((1.0, 0.0, 0.0), 2.0, 0.0, cov)
    assert s["sog_sigma_mps"] == pytest.approx(0.01 / 2.0, rel=1e-12)
    assert s["dcog_sigma_deg"] == pytest.approx(0.1, rel=1e-12)
    assert s["rot_sigma_dps"] == pytest.approx(0.05, rel=1e-12)
    assert s["hdg_sigma_deg"] == s["dcog_sigma_deg"]
