"""Timings of the Python package (reports/performance.md, "The Python package"):

1. register() on the four synthetic marina-like pairs of eval/benches/register_whole.rs, per
   registration, to set against that bench's Rust figure; and the package's overhead alone:
   the same call with a NaN start, which converts the arrays, parses the arguments and builds
   the chain, then is refused before registering (the exception's cost included), so the
   overhead is measured under the same machine load as the call it is part of;
2. a vectorised Python weighting (IR_ICP's scheme) against IR_ICP in Rust in one run, per
   registration, from the run's own per-registration wall times (pairs.csv time_us), with
   one thread and with two (the Python calls take turns under the GIL).

    python icp-py/benches/overhead.py [SCANS]
"""

import csv
import statistics
import sys
import tempfile
import time

import icp_bench

PICKED = [10, 60, 100, 150]


def inverse_range(pairs):
    return 1.0 / (1.0 + 0.5 * (pairs["src_range_m"] + pairs["dst_range_m"]))


def register_us(ds, variant, init=None, repeats=40):
    """Best and median time per registration over `repeats` rounds of the four pairs."""
    scans, sensor = ds.scans, ds.sensor
    pairs = [(scans[k], scans[k + 1]) for k in PICKED]

    def one(src, dst):
        try:
            icp_bench.register(src, dst, variant, init=init, sensor=sensor)
        except icp_bench.InputError:
            assert init is not None

    for src, dst in pairs:  # warm-up
        one(src, dst)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        for src, dst in pairs:
            one(src, dst)
        times.append((time.perf_counter() - start) / len(pairs) * 1e6)
    return min(times), statistics.median(times)


def run_us(uri, threads):
    with tempfile.TemporaryDirectory() as out:
        icp_bench.run(uri, ["IR_ICP"], {"PY_IR": ("H_ICP", inverse_range)}, out=out,
                      plots=False, global_check="off", threads=threads)
        with open(f"{out}/pairs.csv", newline="") as f:
            rows = list(csv.DictReader(f))
    per = {}
    for r in rows:
        per.setdefault(r["variant"], []).append((float(r["time_us"]), int(r["iterations"])))
    return {v: (statistics.median(t for t, _ in x), statistics.mean(i for _, i in x))
            for v, x in per.items()}


def main():
    scans = int(sys.argv[1]) if len(sys.argv) > 1 else 60
    ds = icp_bench.load("synthetic:marina-like")
    nan = (float("nan"), 0.0, 0.0)
    for variant in ["HD_ICP", "IR_ICP", "HD_GICP"]:
        best, median = register_us(ds, variant)
        o_best, o_median = register_us(ds, variant, init=nan)
        print(f"register() {variant}: {best:.0f} us best, {median:.0f} us median per "
              f"registration; overhead alone {o_best:.0f} us best, {o_median:.0f} us median")
    uri = f"synthetic:marina-like?scans={scans}"
    for threads in (1, 2):
        t = run_us(uri, threads)
        (rust, it_r), (py, it_p) = t["IR_ICP"], t["PY_IR"]
        print(f"run threads={threads}: IR_ICP {rust:.0f} us, PY_IR {py:.0f} us per registration "
              f"(median over {scans - 1} pairs; {it_r:.1f} vs {it_p:.1f} iterations): "
              f"+{py - rust:.0f} us, {(py - rust) / it_p:.0f} us per iteration")


if __name__ == "__main__":
    main()
