"""Every bad input of issue 24 is a clear exception (a ValueError or OSError subclass with the
Rust message), never a crash."""

import numpy as np
import pytest

import icp_bench


@pytest.fixture(scope="module")
def scans(small):
    return small.scans[0], small.scans[1]


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda s: s[:, :1], "expected an (n, 2) array of range_m, bearing_rad; got shape [704, 1]"),
        (lambda s: s.T.copy(), "expected an (n, 2) array"),
        (lambda s: s[:, 0].copy(), "expected an (n, 2) float64 numpy array"),
        (lambda s: s.astype(np.float32), "got a ndarray of dtype float32"),
        (lambda s: s.astype(np.int64), "got a ndarray of dtype int64"),
        (lambda s: s.tolist(), "got a list"),
    ],
)
def test_wrong_shape_or_dtype(scans, make, message):
    src, dst = scans
    bad = make(src)
    if isinstance(bad, np.ndarray) and bad.ndim == 2 and bad.shape[0] != 704:
        message = message.replace("[704, 1]", str(list(bad.shape)))
    with pytest.raises(icp_bench.InputError, match=None) as e:
        icp_bench.register(bad, dst)
    assert isinstance(e.value, ValueError)
    assert str(e.value).startswith("source: ")
    assert message.split("; got shape")[0] in str(e.value)


def test_nan_bearing(scans):
    src, dst = scans
    bad = dst.copy()
    bad[5, 1] = np.nan
    with pytest.raises(icp_bench.InputError, match=r"^reference: non-finite bearing at index 5: NaN$"):
        icp_bench.register(src, bad)


def test_negative_range_and_too_few_points(scans):
    src, dst = scans
    bad = src.copy()
    bad[2, 0] = -1.0
    with pytest.raises(icp_bench.InputError, match="negative range at index 2"):
        icp_bench.register(bad, dst)
    with pytest.raises(icp_bench.InputError, match="source scan has 2 usable points, at least 3 are needed"):
        icp_bench.register(src[:2], dst)


def test_unknown_variant(scans):
    with pytest.raises(icp_bench.ConfigError, match='unknown variant "X_ICP": expected one of K_ICP'):
        icp_bench.register(*scans, variant="X_ICP")


@pytest.mark.parametrize(
    "spec, message",
    [
        ({"name": "X", "weighting": "nope", "robust": "none"}, 'unknown weighting kind "nope"'),
        ({"name": "X", "weighting": "uniform", "robust": {"kind": "median_scaled", "c": -1}},
         'robust "median_scaled": c = -1: must be finite and positive'),
        ({"name": "X", "weighting": "uniform"}, "missing field `robust`"),
        ({"name": "X", "weighting": "uniform", "robust": "none", "matchr": "brute"},
         "unknown field `matchr`"),
        ({"name": "a b", "weighting": "uniform", "robust": "none"}, "only letters, digits"),
        ({"name": "X", "weighting": "uniform", "robust": "none", "metric": "point_to_line",
          "minimizer": "weighted_kabsch"},
         "point_to_line needs gauss_newton"),
    ],
)
def test_bad_spec(scans, spec, message):
    with pytest.raises(icp_bench.ConfigError) as e:
        icp_bench.register(*scans, variant=spec)
    assert message in str(e.value)


def test_bad_sensor_and_start(scans):
    with pytest.raises(icp_bench.ConfigError, match="sensor.sigma_r_per_m = -1"):
        icp_bench.register(*scans, variant="HD_ICP",
                           sensor={"sigma_r_const_m": 0, "sigma_r_per_m": -1, "sigma_alpha_rad": 0.01})
    with pytest.raises(icp_bench.ConfigError, match="unknown field `sigma_alpha_deg`"):
        icp_bench.register(*scans, sensor={"sigma_alpha_deg": 0.5})
    with pytest.raises(icp_bench.InputError, match=r"init = \(NaN, 0, 0\): must be finite"):
        icp_bench.register(*scans, init=(float("nan"), 0.0, 0.0))


def test_bad_motion():
    with pytest.raises(icp_bench.InputError, match="dt_s = 0: the time between scans"):
        icp_bench.motion((1.0, 0.0, 0.0), 0.0, 0.0)
    with pytest.raises(icp_bench.ConfigError, match="expected counter_clockwise or clockwise"):
        icp_bench.motion((1.0, 0.0, 0.0), 1.0, 0.0, bearing_sense="up")
    with pytest.raises(icp_bench.InputError, match=r"covariance: expected a \(3, 3\)"):
        icp_bench.motion((1.0, 0.0, 0.0), 1.0, 0.0, covariance=np.eye(2))


def test_bad_datasets(tmp_path):
    with pytest.raises(icp_bench.DataError, match='unknown dataset "bogus"'):
        icp_bench.load("bogus:x")
    with pytest.raises(icp_bench.DataNotFoundError) as e:
        icp_bench.load(f"carmen:{tmp_path}/missing.log")
    assert isinstance(e.value, OSError) and "missing.log" in str(e.value)
    bad = tmp_path / "bad.log"
    bad.write_text("FLASER 3 1.0 2.0\n")
    with pytest.raises(icp_bench.DataError) as e:
        icp_bench.load(f"carmen:{bad}")
    assert "bad.log" in str(e.value)


def test_options_that_do_not_apply(tmp_path, icp_eval):
    """Issue 33: a dataset option the data leave nothing to do for, and the reference's options
    on a dataset without a reference, are refused rather than ignored."""
    import subprocess
    data = tmp_path / "data"
    subprocess.run([icp_eval, "synth", "--scenario", "marina-like", "--scans", "4", "--out",
                    data], check=True, capture_output=True)
    with pytest.raises(icp_bench.DataError, match="option dt_s .* does not apply"):
        icp_bench.load(f"csv:{data}?dt_s=0.5")
    with pytest.raises(icp_bench.DataError, match="option scans = \"1\": at least 2"):
        icp_bench.load(f"csv:{data}?scans=1")
    assert len(icp_bench.load(f"csv:{data}?scans=3")) == 3
    (data / "poses.csv").unlink()
    meta = (data / "dataset.json").read_text().replace('"reference_kind": "ground_truth"',
                                                      '"reference_kind": null')
    (data / "dataset.json").write_text(meta)
    for option, value in [("reference_offset", "auto"), ("reference_checks", "off")]:
        with pytest.raises(icp_bench.ConfigError,
                           match=f"^{option} does not apply to synthetic:marina-like: it has no "
                                 "reference"):
            icp_bench.run(f"csv:{data}", ["HD_ICP"], out=tmp_path / "out", plots=False,
                          **{option: value})
