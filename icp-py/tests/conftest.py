"""Shared fixtures: a small synthetic dataset and the icp-eval binary of this checkout."""

import os
import pathlib
import subprocess

import pytest

import icp_bench

REPO = pathlib.Path(__file__).resolve().parents[2]

# A short synthetic harbour run: ground truth, the dataset's own sensor model.
SMALL = "synthetic:marina-like?scans=8"


@pytest.fixture(scope="session")
def small():
    return icp_bench.load(SMALL)


@pytest.fixture(scope="session")
def icp_eval():
    """The icp-eval binary ($ICP_EVAL, else this checkout's release build, built if missing)."""
    path = os.environ.get("ICP_EVAL")
    if path:
        return pathlib.Path(path)
    subprocess.run(
        ["cargo", "build", "--release", "--locked", "-q", "-p", "eval", "--bin", "icp-eval"],
        cwd=REPO,
        check=True,
    )
    return REPO / "target" / "release" / "icp-eval"
