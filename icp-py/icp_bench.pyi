"""icp_bench: the icp-bench variants from numpy, and weighting schemes written in Python run
through the evaluation harness (Naus & Marchel 2019, weighted ICP for 2D LIDAR)."""

from os import PathLike
from typing import Any, Callable, Mapping, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

Pose = Tuple[float, float, float]
"""(tx_m, ty_m, theta_rad): maps source points into the reference scan's frame."""

VariantSpec = Union[str, Mapping[str, Any]]
"""A built-in variant's name (any case) or a variant spec as a dict, like a configuration
file of configs/variants/."""

Weighting = Callable[[dict[str, Any]], npt.ArrayLike]
"""Gets one dict per iteration: float64 arrays src_range_m, dst_range_m, src_bearing_rad,
dst_bearing_rad, src_x_m, src_y_m (the source points moved by the current estimate),
dst_x_m, dst_y_m, normal_x, normal_y (the reference surface's unit normal, NaN where there is
none), and the floats rotation_rad (of the current estimate) and int iteration. Returns one
weight per pair, finite and >= 0."""

class InputError(ValueError):
    """Input a registration refuses (wrong shape or dtype, NaN bearing, too few points)."""

class ConfigError(ValueError):
    """An unknown variant, a bad spec or sensor, an option outside its domain."""

class DataError(ValueError):
    """A dataset URI or file whose content cannot be used."""

class DataNotFoundError(OSError):
    """A dataset file that is not there or cannot be read."""

class OutputError(OSError):
    """An output directory or file that cannot be written."""

class WeightingError(ValueError):
    """A Python weighting that raised or returned bad weights; names variant, pair, iteration."""

class Dataset:
    """A loaded dataset."""

    @property
    def name(self) -> str: ...
    @property
    def scans(self) -> list[npt.NDArray[np.float64]]:
        """One (n, 2) array of range_m, bearing_rad per scan (valid returns only)."""
    @property
    def timestamps(self) -> npt.NDArray[np.float64]:
        """Each scan's time, s: its own timestamp, else index * dt_s."""
    @property
    def dt_s(self) -> float: ...
    @property
    def reference(self) -> npt.NDArray[np.float64] | None:
        """(n, 3) x_m, y_m, heading_rad per scan, or None."""
    @property
    def reference_kind(self) -> str | None: ...
    @property
    def reference_heading_sense(self) -> str: ...
    @property
    def bearing_sense(self) -> str:
        """counter_clockwise or clockwise (for motion())."""
    @property
    def sensor(self) -> dict[str, float]:
        """sigma_r_const_m, sigma_r_per_m, sigma_alpha_rad (what register(sensor=) takes)."""
    @property
    def warnings(self) -> list[str]: ...
    def __len__(self) -> int: ...

class Registration:
    """The outcome of one registration."""

    @property
    def variant(self) -> str: ...
    @property
    def t_ref_src(self) -> Pose: ...
    @property
    def theta_deg(self) -> float: ...
    @property
    def covariance(self) -> npt.NDArray[np.float64] | None:
        """(3, 3) over (tx m, ty m, theta rad) as icp-eval reports it, or None."""
    @property
    def covariance_unbounded(self) -> bool: ...
    @property
    def iterations(self) -> int: ...
    @property
    def stop_reason(self) -> str: ...
    @property
    def converged(self) -> bool: ...
    @property
    def status(self) -> str:
        """ok, degenerate or no_overlap (no global check is made)."""
    @property
    def status_reason(self) -> str: ...
    @property
    def degenerate(self) -> bool: ...
    @property
    def no_overlap(self) -> bool: ...
    @property
    def cond_ratio(self) -> float | None: ...
    @property
    def overlap(self) -> float: ...
    @property
    def n_pairs(self) -> int: ...
    @property
    def n_unusable(self) -> int: ...
    @property
    def weight_sum(self) -> float: ...
    @property
    def mean_residual_m(self) -> float: ...

def variants() -> list[str]:
    """The built-in variants' names."""

def kinds() -> dict[str, Any]:
    """The registry (variants, stage families with kinds and parameters, sections), as
    `icp-eval list` shows it."""

def load(uri: str) -> Dataset:
    """A dataset by the URIs of `icp-eval run --dataset` (e.g. synthetic:marina-like?scans=20)."""

def register(
    source: npt.NDArray[np.float64],
    reference: npt.NDArray[np.float64],
    variant: VariantSpec | None = None,
    init: Pose | None = None,
    sensor: Mapping[str, float] | None = None,
) -> Registration:
    """Registers source (scan k) onto reference (scan k+1), (n, 2) float64 arrays of
    range_m, bearing_rad; variant defaults to HD_GICP, init to the identity."""

def motion(
    t_ref_src: Pose,
    dt_s: float,
    heading_deg: float,
    covariance: npt.NDArray[np.float64] | None = None,
    bearing_sense: str = "counter_clockwise",
) -> dict[str, float | None]:
    """sog_mps, dcog_deg, rot_dps, hdg_deg and their *_sigma_* (None without covariance)."""

def run(
    uri: str,
    variants: Sequence[VariantSpec] | None = None,
    weightings: Mapping[str, Tuple[str, Weighting]] | None = None,
    *,
    out: Union[str, PathLike[str]],
    reference_offset: int | str = 0,
    reference_checks: str = "on",
    init: str = "identity",
    global_check: str = "on",
    start_gate: str | float = "auto",
    global_window_m: float = ...,
    global_rotation: str = "histogram",
    covariance: str = "extended",
    estimates: Sequence[str] = (),
    lags: int = 1,
    matcher: str | None = None,
    huber_c: float | None = None,
    seed: int | None = None,
    sensor: Mapping[str, float] | str | None = None,
    threads: int | None = None,
    plots: bool = True,
    force: bool = False,
) -> dict[str, Any]:
    """`icp-eval run` with its options as keywords: variants (default the four of Table 1)
    and weightings {NAME: (BASE_VARIANT, fn)} over every consecutive pair of uri; writes the
    run's files into out and returns summary.json as a dict. lags > 1 also registers k → k+ℓ
    for 2 ≤ ℓ ≤ lags and writes cycles.csv, as --lags does."""

def compare(
    uri: str,
    variants: Sequence[VariantSpec] | None = None,
    weightings: Mapping[str, Tuple[str, Weighting]] | None = None,
    *,
    out: Union[str, PathLike[str]],
    bootstrap: int = 10_000,
    bootstrap_seed: int = 0,
    **options: Any,
) -> dict[str, Any]:
    """run(), then every pair of variants compared as `icp-eval compare` does (bootstrap
    interval, Wilcoxon and Holm-adjusted p-values on |SOG error| and |dCOG error|); writes
    compare.md and compare.json beside the run's files and returns compare.json as a dict.
    options: those of run()."""
