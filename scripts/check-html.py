#!/usr/bin/env python3
"""Checks a report.html as a browser rendered it (see check-html.sh): the DOM Chromium dumped
after running the page's script, and its screenshot.

usage: check-html.py OUT_DIR DUMPED_DOM SCREENSHOT_PNG
"""
import os
import re
import struct
import sys


def main() -> int:
    out, dom_path, png = sys.argv[1:4]
    dom = open(dom_path, encoding="utf-8", errors="replace").read()
    errors = []
    ready = re.search(r'data-sort-ready="(\d+)"', dom)
    if not ready or int(ready.group(1)) == 0:
        errors.append("the page's script did not run (no data-sort-ready on <body>)")
    stems = sorted(f[:-4] for f in os.listdir(out) if f.endswith(".svg"))
    shown = sorted(set(re.findall(r'<figure id="[^"]*" data-figure="([^"]+)"><svg', dom)))
    if stems != shown:
        errors.append(f"figures rendered {shown}, files {stems}")
    if not os.path.exists(png):
        errors.append("no screenshot")
    else:
        with open(png, "rb") as f:
            head = f.read(24)
        width, height = struct.unpack(">II", head[16:24])
        size = os.path.getsize(png)
        # A blank page compresses to a few kB; ours has tables and figures.
        if head[:8] != b"\x89PNG\r\n\x1a\n" or width != 1280 or size < 30_000:
            errors.append(f"screenshot {width}x{height}, {size} bytes: blank or missing")
    name = os.path.basename(out.rstrip("/"))
    for e in errors:
        print(f"check-html: {name}: {e}", file=sys.stderr)
    if not errors:
        print(f"check-html: {name}: script ran ({ready.group(1)} sortable tables), "
              f"{len(shown)} figures inline, screenshot drawn")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
