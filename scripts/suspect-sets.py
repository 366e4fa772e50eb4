#!/usr/bin/env python3
"""The pairs each built-in variant's result is flagged `suspect` on, per dataset and init mode.

The global check (issue 25) may change how it searches, never what it decides. This records the
decisions of a binary and compares them with a recorded file:

    scripts/suspect-sets.py record OUT.json [--datasets synthetic,marina,aces]
    scripts/suspect-sets.py compare RECORDED.json [--datasets synthetic]

Each run is `icp-eval run --dataset D --variants ALL --init I --no-plots --quiet` with the
default global check, I in identity, global and the chain constant-velocity,identity (whose
starts depend on the previous result's status). Needs ICP_DATA_DIR for marina and aces and a
release build (`cargo build --release -p eval`). `compare` exits 1 when a set differs.
"""

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile

VARIANTS = "K_ICP,H_ICP,HM_ICP,HD_ICP,IR_ICP,PL_ICP,HD_PL_ICP,GICP,HD_GICP"
INITS = ["identity", "global", "constant-velocity,identity"]
BINARY = os.path.join(os.path.dirname(__file__), "..", "target", "release", "icp-eval")


def dataset_arg(name):
    if name == "aces":
        return "carmen:" + os.path.join(os.environ["ICP_DATA_DIR"], "carmen", "aces.log.gz")
    return name


def command(dataset, init, out):
    return [BINARY, "run", "--dataset", dataset_arg(dataset), "--variants", VARIANTS,
            "--init", init, "--no-plots", "--quiet", "--out", out]


def suspect_sets(dataset, init):
    """{variant: sorted pair indices flagged suspect}, and the pairs checked."""
    with tempfile.TemporaryDirectory() as out:
        subprocess.run(command(dataset, init, out), check=True, stdout=subprocess.DEVNULL)
        sets = {v: [] for v in VARIANTS.split(",")}
        pairs = set()
        with open(os.path.join(out, "pairs.csv"), newline="") as f:
            for row in csv.DictReader(f):
                pairs.add(int(row["pair"]))
                if row["status"] == "suspect":
                    sets[row["variant"]].append(int(row["pair"]))
    return {"pairs": len(pairs), "suspect": {v: sorted(p) for v, p in sets.items()}}


def record(datasets):
    runs = {}
    for d in datasets:
        for init in INITS:
            key = f"{d}/{init}"
            runs[key] = suspect_sets(d, init)
            runs[key]["command"] = " ".join(command(d, init, "OUT")).replace(
                os.environ.get("ICP_DATA_DIR", "\0"), "$ICP_DATA_DIR")
            print(key, {v: len(p) for v, p in runs[key]["suspect"].items()}, file=sys.stderr)
    return runs


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("action", choices=["record", "compare"])
    parser.add_argument("file")
    parser.add_argument("--datasets", default="synthetic,marina,aces")
    args = parser.parse_args()
    datasets = args.datasets.split(",")
    if args.action == "record":
        with open(args.file, "w") as f:
            json.dump(record(datasets), f, indent=1)
            f.write("\n")
        return 0
    with open(args.file) as f:
        recorded = json.load(f)
    now = record(datasets)
    differ = 0
    for key, run in now.items():
        if key not in recorded:
            print(f"{key}: not in {args.file}", file=sys.stderr)
            differ = 1
        elif run["suspect"] != recorded[key]["suspect"] or run["pairs"] != recorded[key]["pairs"]:
            print(f"{key}: differs from {args.file}", file=sys.stderr)
            differ = 1
        else:
            print(f"{key}: same suspect sets", file=sys.stderr)
    return differ


if __name__ == "__main__":
    sys.exit(main())
