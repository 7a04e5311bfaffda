#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Draw modrt-bench's run-time-versus-error chart.

usage: plot_bench.py BENCH.csv OUT.png

One panel per scene (columns) and per case (rows): in-prior lights with one bounce,
in-prior lights with multi-bounce, out-of-prior lights with one bounce. A point is one
method configuration (method, kb, resolution); in-prior points are the mean over the
in-prior light placements, out-of-prior points the mean over the out-of-prior ones (the two
are never mixed). x: median time per frame (ms, log); y: relative L2 error vs the path
traced ground truth. The Pareto front (no other point both faster and more accurate) is
drawn as a step line; the dotted line is the ground truth's noise floor.
"""
import csv
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

STYLE = {
    "mrt": ("o", "tab:blue"),
    "mrt_converged": ("v", "tab:brown"),
    "mrt_cpu": ("P", "tab:green"),
    "mrt_gles": ("*", "tab:cyan"),
    "svd_F": ("s", "tab:orange"),
    "dense_F": ("D", "tab:red"),
    "raytraced_F": ("^", "tab:purple"),
    "ambient": ("x", "tab:gray"),
}
MIN_MS = 1e-4  # a constant fill can time below the clock's resolution


def load(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def pareto(points):
    """points: (time, err, ...) -> the Pareto-optimal ones sorted by time."""
    front, best = [], float("inf")
    for p in sorted(points, key=lambda p: (p[0], p[1])):
        if p[1] < best:
            front.append(p)
            best = p[1]
    return front


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    rows = load(sys.argv[1])
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    multi = max(int(r["bounces"]) for r in rows)
    cases = [("in prior, 1 bounce", True, 1), (f"in prior, multi-bounce ({multi} bounces, converged)", True, multi),
             ("OUT of prior, 1 bounce", False, 1)]
    cases = [c for c in cases if any((r["in_prior"] == "1") == c[1] and int(r["bounces"]) == c[2] for r in rows)]
    fig, axes = plt.subplots(len(cases), len(scenes), figsize=(4.2 * len(scenes), 3.6 * len(cases)), squeeze=False)
    for ci, (title, in_prior, bounces) in enumerate(cases):
        for si, scene in enumerate(scenes):
            ax = axes[ci][si]
            groups = defaultdict(list)
            noise = []
            for r in rows:
                if r["scene"] != scene or (r["in_prior"] == "1") != in_prior or int(r["bounces"]) != bounces:
                    continue
                groups[(r["method"], int(r["kb"]), int(r["res"]))].append(r)
                noise.append(float(r["noise_floor"]))
            points = []
            for (method, kb, res), rs in groups.items():
                t = max(MIN_MS, sum(float(r["time_ms"]) for r in rs) / len(rs))
                e = sum(float(r["rel_l2"]) for r in rs) / len(rs)
                points.append((t, e, method, kb, res))
            if not points:
                ax.set_visible(False)
                continue
            for method, (marker, colour) in STYLE.items():
                for res, fill in ((6, "none"), (16, colour)):
                    pts = [p for p in points if p[2] == method and p[4] == res]
                    if not pts:
                        continue
                    style = {"c": colour} if marker == "x" else {"facecolors": fill, "edgecolors": colour}
                    ax.scatter([p[0] for p in pts], [p[1] for p in pts], marker=marker, s=34,
                               label=f"{method} res {res}", **style)
                    if method in ("mrt", "svd_F"):
                        for p in pts:
                            ax.annotate(str(p[3]), (p[0], p[1]), fontsize=6, xytext=(3, 2),
                                        textcoords="offset points", color=colour)
            front = pareto(points)
            ax.step([p[0] for p in front], [p[1] for p in front], where="post", color="black", lw=0.9,
                    alpha=0.6, label="Pareto front")
            ax.scatter([p[0] for p in front], [p[1] for p in front], s=90, facecolors="none",
                       edgecolors="black", lw=0.8)
            if noise:
                ax.axhline(max(noise), color="gray", ls=":", lw=0.8, label="GT noise floor (max)")
            ax.set_xscale("log")
            ax.set_ylim(bottom=0)
            ax.set_title(f"{scene}: {title}", fontsize=9)
            ax.grid(True, which="both", alpha=0.25)
            if ci == len(cases) - 1:
                ax.set_xlabel("time per frame (ms, log)")
            if si == 0:
                ax.set_ylabel("relative L2 error vs ground truth")
    handles, labels = {}, []
    for ax in axes.flat:
        for h, l in zip(*ax.get_legend_handles_labels()):
            if l not in handles:
                handles[l] = h
                labels.append(l)
    fig.legend([handles[l] for l in labels], labels, loc="lower center", ncol=min(6, len(labels)), fontsize=8)
    fig.suptitle("modrt: run time vs error (numbers next to points: rank k; hollow = res 6, filled = res 16)",
                 fontsize=10)
    fig.tight_layout(rect=(0, 0.06, 1, 0.97))
    fig.savefig(sys.argv[2], dpi=110)


if __name__ == "__main__":
    main()
