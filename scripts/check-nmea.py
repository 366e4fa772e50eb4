#!/usr/bin/env python3
"""Checks an icp-eval run's `V+causal.nmea` files with an independent parser (PyPI `pynmea2`).

For every causal estimator in DIR/summary.json's `sequence` that gave an estimate:
  - every line of `DIR/<V+causal>.nmea` ends in CRLF and parses with pynmea2 with its checksum
    verified (`check=True`), talker `II`;
  - the sentences come in groups ZDA, VTG, ROT, HDT, one group per row of sequence.csv of that
    estimator, in order;
  - ZDA's date and time equal the row's `time_s` (seconds since 1970-01-01 00:00:00 UTC);
  - a row with `supported` true: VTG's mode `A`, its speed in knots and km/h the row's
    `sog_mps`, ROT's status `A` and its rate (degrees per minute) the row's `rot_dps` × 60,
    and, when summary.json says the headings start from the reference's, VTG's course and
    HDT's heading the row's `cog_deg` and `hdg_deg` (else both empty);
  - a row with `supported` false: VTG's mode `N`, ROT's status `V`, every figure empty.

A figure must equal the row's to the sentence's precision: within half a unit of the last
decimal written (angles compared modulo 360).

Usage: check-nmea.py DIR   (exit 1 on any disagreement, naming it; prints what it checked)
"""

import csv
import datetime
import json
import os
import sys

import pynmea2

KNOTS_PER_MPS = 3600.0 / 1852.0
EPOCH = datetime.datetime(1970, 1, 1, tzinfo=datetime.timezone.utc)


class Disagreement(Exception):
    pass


def half_unit(field):
    """Half a unit of the last decimal of a written figure (plus float slack)."""
    decimals = len(field.split(".")[1]) if "." in field else 0
    return 0.5 * 10.0 ** -decimals + 1e-9


def close(where, field, expected, angle=False):
    if field == "":
        raise Disagreement(f"{where}: empty, expected {expected}")
    diff = float(field) - expected
    if angle:
        diff = (diff + 180.0) % 360.0 - 180.0
    if abs(diff) > half_unit(field):
        raise Disagreement(f"{where}: {field} written, {expected} in sequence.csv")


def empty(where, *fields):
    if any(f not in ("", None) for f in fields):
        raise Disagreement(f"{where}: {fields} written where the estimate is missing")


def parse(path):
    with open(path, "rb") as f:
        data = f.read()
    if not data.endswith(b"\r\n"):
        raise Disagreement(f"{path}: does not end in CRLF")
    lines = data[:-2].split(b"\r\n")
    out = []
    for i, line in enumerate(lines):
        if b"\n" in line or b"\r" in line:
            raise Disagreement(f"{path} line {i + 1}: a line end other than CRLF")
        msg = pynmea2.parse(line.decode("ascii"), check=True)
        if msg.talker != "II":
            raise Disagreement(f"{path} line {i + 1}: talker {msg.talker}")
        out.append(msg)
    return out


def check_group(where, group, row, heading):
    zda, vtg, rot, hdt = group
    kinds = [type(m).__name__ for m in group]
    if kinds != ["ZDA", "VTG", "ROT", "HDT"]:
        raise Disagreement(f"{where}: sentences {kinds}, expected ZDA, VTG, ROT, HDT")
    time_s = float(row["time_s"])
    written = datetime.datetime.combine(
        datetime.date(int(zda.year), int(zda.month), int(zda.day)),
        zda.timestamp.replace(tzinfo=datetime.timezone.utc),
    )
    if abs((written - EPOCH).total_seconds() - time_s) > 0.005 + 1e-6:
        raise Disagreement(f"{where}: ZDA {written.isoformat()}, time_s {time_s}")
    if row["supported"] == "false":
        if vtg.faa_mode != "N" or rot.status != "V":
            raise Disagreement(f"{where}: unsupported scan with VTG mode {vtg.faa_mode}, ROT {rot.status}")
        empty(where, vtg.true_track, vtg.spd_over_grnd_kts, vtg.spd_over_grnd_kmph, rot.rate_of_turn, hdt.heading)
        return False
    if vtg.faa_mode != "A" or rot.status != "A":
        raise Disagreement(f"{where}: VTG mode {vtg.faa_mode}, ROT status {rot.status}")
    sog = float(row["sog_mps"])
    close(f"{where} VTG knots", vtg.data[4], sog * KNOTS_PER_MPS)
    close(f"{where} VTG km/h", vtg.data[6], sog * 3.6)
    close(f"{where} ROT", rot.data[0], float(row["rot_dps"]) * 60.0)
    if heading:
        close(f"{where} VTG course", vtg.data[0], float(row["cog_deg"]), angle=True)
        close(f"{where} HDT", hdt.data[0], float(row["hdg_deg"]), angle=True)
    else:
        empty(where, vtg.data[0], hdt.data[0])
    return True


def main(run):
    with open(os.path.join(run, "summary.json")) as f:
        summary = json.load(f)
    with open(os.path.join(run, "sequence.csv"), newline="") as f:
        rows = list(csv.DictReader(f))
    checked = 0
    for est in summary.get("sequence", []):
        method = est["method"]
        if not method.endswith("+causal"):
            continue
        own = [r for r in rows if r["method"] == method]
        path = os.path.join(run, method + ".nmea")
        if not own:
            if os.path.exists(path):
                raise Disagreement(f"{path}: written for an estimator that gave nothing")
            print(f"check-nmea: {method} gave nothing ({est.get('error')}), no file: ok")
            continue
        msgs = parse(path)
        if len(msgs) != 4 * len(own):
            raise Disagreement(f"{path}: {len(msgs)} sentences for {len(own)} scans")
        heading = est["heading_from_reference"]
        supported = sum(
            check_group(f"{path} scan {row['scan']}", msgs[4 * i : 4 * i + 4], row, heading)
            for i, row in enumerate(own)
        )
        print(
            f"check-nmea: {method}: {len(own)} scans, {supported} with figures, "
            f"{len(own) - supported} with empty fields, headings {'true' if heading else 'empty'}: ok"
        )
        checked += 1
    if checked == 0:
        raise Disagreement(f"{run}: no V+causal.nmea checked")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    try:
        main(sys.argv[1])
    except (Disagreement, pynmea2.ParseError) as e:
        print(f"check-nmea: {e}", file=sys.stderr)
        sys.exit(1)
