"""icp_bench: the icp-bench variants from numpy, and weighting schemes written in Python run
through the evaluation harness (Naus & Marchel 2019, weighted ICP for 2D LIDAR)."""

from os import PathLike
from typing import Any, Callable, Mapping, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

Pose = Tuple[float, float, float]
"""(tx_m, ty_m, theta_rad): maps source points into the reference scan's frame. tx_m, ty_m in
metres; theta_rad in radians (not degrees), from the scan frame's +x towards its +y."""

VariantSpec = Union[str, Mapping[str, Any]]
"""A built-in variant's name (any case) or a variant spec as a dict, like a configuration
file of configs/variants/."""

Weighting = Callable[[dict[str, Any]], npt.ArrayLike]
"""Gets one dict per iteration, one value per pair in each float64 array:

- src_range_m, dst_range_m: the ranges of the source return (scan k) and of the reference
  return (scan k+1), metres;
- src_bearing_rad, dst_bearing_rad: their bearings, radians, growing in the dataset's
  bearing_sense;
- src_x_m, src_y_m: the source point moved by the current estimate into the reference scan's
  frame, metres;
- dst_x_m, dst_y_m: the reference point in the reference scan's frame, metres;
- normal_x, normal_y: the reference surface's unit normal there (unitless, reference scan's
  frame), NaN where there is none;
- src_sigma_r_m, dst_sigma_r_m: the range standard deviation of each return, metres, from the
  variant's sensor model (the run's, after sensor=): sigma_r_const_m + sigma_r_per_m * range
  (eq. 8 of the paper);
- src_sigma_alpha_rad, dst_sigma_alpha_rad: the bearing standard deviation of each return,
  radians (the sensor model's sigma_alpha_rad, the same for every return);

and rotation_rad (float: the rotation of the current estimate t_ref_src, radians) and
iteration (int, 0 first). Returns one weight per pair, finite and >= 0 (unitless as far as the
harness is concerned: only their ratios matter to the minimiser)."""

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
        """One (n, 2) array per scan of range_m (metres) and bearing_rad (radians, growing in
        bearing_sense), valid returns only."""
    @property
    def timestamps(self) -> npt.NDArray[np.float64]:
        """Each scan's time, seconds: its own timestamp, else index * dt_s."""
    @property
    def dt_s(self) -> float:
        """The nominal time between scans, seconds."""
    @property
    def reference(self) -> npt.NDArray[np.float64] | None:
        """(n, 3) per scan: x_m, y_m (metres), heading_rad (radians, growing in
        reference_heading_sense); or None without a reference."""
    @property
    def reference_kind(self) -> str | None:
        """What the reference is (e.g. "ground truth (exact)"), or None without one."""
    @property
    def reference_heading_sense(self) -> str:
        """counter_clockwise or clockwise."""
    @property
    def bearing_sense(self) -> str:
        """counter_clockwise or clockwise (for motion())."""
    @property
    def sensor(self) -> dict[str, float]:
        """sigma_r_const_m (metres), sigma_r_per_m (metres per metre of range),
        sigma_alpha_rad (radians): sigma_r = sigma_r_const_m + sigma_r_per_m * range (what
        register(sensor=) takes)."""
    @property
    def warnings(self) -> list[str]:
        """What the loader noticed, one sentence each."""
    def __len__(self) -> int:
        """The number of scans."""

class Registration:
    """The outcome of one registration."""

    @property
    def variant(self) -> str: ...
    @property
    def t_ref_src(self) -> Pose:
        """(tx_m, ty_m, theta_rad): metres, metres and RADIANS (theta_deg has it in degrees;
        the repr prints degrees); maps source points into the reference scan's frame."""
    @property
    def theta_deg(self) -> float:
        """The rotation of t_ref_src in degrees, as pairs.csv's theta_deg."""
    @property
    def covariance(self) -> npt.NDArray[np.float64] | None:
        """(3, 3) over (tx, ty, theta) as icp-eval reports it: m² for the translations, m·rad
        between a translation and theta, rad² for theta; or None."""
    @property
    def covariance_unbounded(self) -> bool: ...
    @property
    def iterations(self) -> int:
        """Minimisation steps taken (a count)."""
    @property
    def stop_reason(self) -> str:
        """converged, small_update, repeated_matching or max_iterations."""
    @property
    def converged(self) -> bool: ...
    @property
    def status(self) -> str:
        """ok, degenerate or no_overlap (no global check is made)."""
    @property
    def status_reason(self) -> str:
        """Why the status is not ok, with its figures (empty when it is)."""
    @property
    def degenerate(self) -> bool: ...
    @property
    def no_overlap(self) -> bool: ...
    @property
    def cond_ratio(self) -> float | None:
        """Smallest over largest eigenvalue of the Hessian at the solution (unitless)."""
    @property
    def overlap(self) -> float:
        """The smaller of the fractions (0 to 1) of source and reference points near the other
        scan."""
    @property
    def n_pairs(self) -> int:
        """Pairs the metric used at the solution (a count)."""
    @property
    def n_unusable(self) -> int:
        """Pairs the metric could not use at the solution (a count)."""
    @property
    def weight_sum(self) -> float:
        """Sum of the final pair weights of the last step, in the weighting's own units."""
    @property
    def mean_residual_m(self) -> float:
        """Mean residual of the used pairs after the final estimate, metres."""

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
    range_m (metres), bearing_rad (radians); variant defaults to HD_GICP, init (a Pose:
    metres, metres, radians) to the identity; sensor as Dataset.sensor."""

def motion(
    t_ref_src: Pose,
    dt_s: float,
    heading_deg: float,
    covariance: npt.NDArray[np.float64] | None = None,
    bearing_sense: str = "counter_clockwise",
) -> dict[str, float | None]:
    """The step t_ref_src (a Pose: metres, metres, radians) taken over dt_s seconds from
    heading_deg (degrees): sog_mps (m/s), dcog_deg (degrees in (-180, 180], clockwise
    positive), rot_dps (degrees per second, clockwise positive), hdg_deg (degrees in
    [0, 360)) and their standard errors sog_sigma_mps, dcog_sigma_deg, rot_sigma_dps,
    hdg_sigma_deg in the same units (None without covariance, a (3, 3) array in the units of
    Registration.covariance)."""

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
    sequence: Sequence[str] | str = (),
    motion_prior: str = "white_acceleration",
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
    run's files into out and returns summary.json as a dict (its units are in its keys'
    suffixes: _m, _deg, _mps, _dps, _s; eval/README.md documents it). lags > 1 also registers
    k → k+ℓ for 2 ≤ ℓ ≤ lags and writes cycles.csv, as --lags does. sequence (["batch",
    "causal"] or "batch,causal", as --sequence) adds the smoothed estimators V+batch, V+causal
    of each variant with a covariance, sequence.csv and V+causal.nmea; motion_prior
    ("white_acceleration", "white_jerk" or "likelier", as --motion-prior) is their prior.
    reference_offset: scans
    (the default, 0, never applies an offset) or "auto" (the estimated one);
    reference_offset and reference_checks are refused on a dataset without a reference."""

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
