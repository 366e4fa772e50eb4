#!/usr/bin/env python3
"""The comparison tables of the external runs, from the files icp-eval and the tools wrote.

For each dataset directory (`reports/external/aces`, …): every run under it (`identity/`,
`global/`) as one table from its summary.json (schema in eval/README.md): per variant, built-in
or external, the success rate (within 0.1 m and 1°; null without a rigid reference), the RMSE
of SOG, ΔCOG, translation and rotation over the run's population (the pairs every variant
registered), the failure rate (any status but `ok`: flagged or not registered), the flags'
recall and precision (a pair is wrong beyond 0.3 m or 3°) and the median time per pair
(icp-eval's for the built-in variants, the tool's own wall clock from `tool-stats/` for the
external ones; KISS-ICP: per scan).

    tables.py reports/external/aces reports/external/synthetic-paper > tables.md
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

RUNS = ("identity", "global")


def cell(value, digits: int) -> str:
    return "–" if value is None else f"{value:.{digits}f}"


def rmse(stats: dict, key: str):
    entry = stats.get(key)
    return entry["rmse"] if entry else None


def tool_time_ms(dataset_dir: Path, name: str):
    path = dataset_dir / "tool-stats" / f"{name}.json"
    if not path.exists():
        return None
    s = json.loads(path.read_text())
    return s.get("time_per_pair_ms_median", s.get("time_per_scan_ms_median"))


def table(dataset_dir: Path, run: str) -> str:
    summary_path = dataset_dir / run / "summary.json"
    s = json.loads(summary_path.read_text())
    external = {e["name"] for e in s["config"].get("estimates", [])}
    lines = [
        f"### {s['dataset']['name']}, `--init {','.join(s['config']['init'])}` "
        f"(`{summary_path}`, population {s['population']['pairs']} of {s['dataset']['pairs']} pairs)",
        "",
        "| variant | success (0.1 m, 1°) | SOG RMSE m/s | ΔCOG RMSE ° | trans RMSE m | rot RMSE ° "
        "| trans median m | failure rate | flag recall | flag precision | median ms/pair |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for v in s["variants"]:
        a = v["all_pairs"]
        q = v.get("flag_quality") or {}
        trans = a.get("trans_err_m")
        if v["name"] in external:
            name, ms = f"{v['name']} (ext.)", tool_time_ms(dataset_dir, v["name"])
        else:
            name, ms = v["name"], v["timing"]["median_us"] / 1e3 if v.get("timing") else None
        lines.append(
            f"| {name} | {cell(v.get('success_rate'), 3)} | {cell(rmse(a, 'sog_err_mps'), 3)} "
            f"| {cell(rmse(a, 'dcog_err_deg'), 2)} | {cell(rmse(a, 'trans_err_m'), 3)} "
            f"| {cell(rmse(a, 'rot_err_deg'), 2)} | {cell(trans['median_abs'] if trans else None, 3)} "
            f"| {cell(v['failure_rate'], 3)} | {cell(q.get('recall'), 3)} | {cell(q.get('precision'), 3)} "
            f"| {cell(ms, 2)} |"
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    print("<!-- written by scripts/external/tables.py; redo with scripts/external/run-all.sh -->\n")
    for d in map(Path, sys.argv[1:]):
        for run in RUNS:
            if (d / run / "summary.json").exists():
                print(table(d, run))


if __name__ == "__main__":
    main()
