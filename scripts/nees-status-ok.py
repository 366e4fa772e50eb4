#!/usr/bin/env python3
"""ANEES/3 and the share of NEES inside chi2(3)'s 95 % interval per variant of a run, over every
pair registered by all variants and over those whose status is ok (a stand-in for issue 21's
`consistency.nees_unflagged` until it lands).

    scripts/nees-status-ok.py RUN_DIR [RUN_DIR ...]   # each holding a pairs.csv
"""
import csv
import sys

LO, HI = 0.2158, 9.3484  # chi2(3) 2.5 % and 97.5 % quantiles


def figures(nees):
    if not nees:
        return "no pairs"
    inside = sum(1 for e in nees if LO <= e <= HI) / len(nees)
    return f"ANEES/3 {sum(nees) / len(nees) / 3:.2f}, {inside:.3f} inside ({len(nees)} pairs)"


for run in sys.argv[1:]:
    rows = list(csv.DictReader(open(f"{run}/pairs.csv")))
    for variant in sorted({r["variant"] for r in rows}):
        mine = [r for r in rows if r["variant"] == variant and r["nees"] and r["all_registered"] == "true"]
        ok = [float(r["nees"]) for r in mine if r["status"] == "ok"]
        print(f"{run} {variant}: all {figures([float(r['nees']) for r in mine])}; status ok {figures(ok)}")
