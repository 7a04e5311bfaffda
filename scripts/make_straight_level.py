#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes a straight corridor level (docs/level-format.md): N blocks along +Z joined through
their shared faces, a light in each end block. The worst case of the direct-light pass's shadow
rays (every sample sees both lights down the whole corridor; issue 18, item 10).

  scripts/make_straight_level.py 1000 > /tmp/straight1000.json
  modrt-level --level /tmp/straight1000.json --bounces 0
"""
import json
import sys


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 300
    if n < 1:
        sys.exit("make_straight_level.py: N must be >= 1")
    blocks = []
    for i in range(n):
        missing = ([] if i == 0 else ["-Z"]) + ([] if i == n - 1 else ["+Z"])
        blocks.append({"cell": [0, 0, i], "missing": missing})
    level = {
        "format": "modrt-level",
        "version": 1,
        "name": "straight%d" % n,
        "blocks": blocks,
        "lights": [
            {"position": [0.5, 0.5, 0.5], "radius": 0.05, "intensity": 1.0},
            {"position": [0.5, 0.5, n - 0.5], "radius": 0.05, "intensity": 1.0},
        ],
    }
    json.dump(level, sys.stdout, indent=1)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
