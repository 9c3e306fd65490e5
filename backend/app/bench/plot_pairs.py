#!/usr/bin/python3
"""Time against distance for distlab-bench-pairs' per-pair CSV (plain or .gz).

    /usr/bin/python3 backend/app/bench/plot_pairs.py pairs.csv.gz pairs.png

Left: GAP Newton's and FCL's time per pair against the Euclidean distance (log scale; touching
pairs at <= 1e-6), a sample of the points and the median per distance decade. Right: the
overlapping pairs' times (distance 0) as box plots.
"""
import csv
import gzip
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt", newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows or "gap_us" not in rows[0]:
        raise ValueError(f"{path}: not a distlab-bench-pairs CSV (no gap_us column)")
    return rows


def medians(xs, ys, per_decade=4):
    bins = {}
    for x, y in zip(xs, ys):
        bins.setdefault(math.floor(math.log10(x) * per_decade), []).append(y)
    out = []
    for b in sorted(bins):
        v = sorted(bins[b])
        out.append((10 ** ((b + 0.5) / per_decade), v[len(v) // 2]))
    return out


def main(argv):
    if len(argv) != 3:
        raise SystemExit("usage: plot_pairs.py PAIRS.csv[.gz] OUT.png")
    rows = read(argv[1])
    apart = [r for r in rows if r["regime"] != "overlapping"]
    overlap = [r for r in rows if r["regime"] == "overlapping"]
    fig, (ax, ax_o) = plt.subplots(1, 2, figsize=(12, 5), gridspec_kw={"width_ratios": [4, 1]}, sharey=True)
    step = max(1, len(apart) // 20000)  # a sample of the points; the medians use all
    d = [float(r["euclidean_distance"]) for r in apart]
    for column, colour, name in (("fcl_us", "tab:blue", "FCL distance"), ("gap_us", "tab:red", "GAP Newton")):
        t = [float(r[column]) for r in apart]
        ax.scatter(d[::step], t[::step], s=2, alpha=0.15, color=colour, linewidths=0)
        # one median line per regime: no line across the empty decades between them
        for k, regime in enumerate(("touching", "separated")):
            pts = [(x, y) for x, y, r in zip(d, t, apart) if r["regime"] == regime]
            if pts:
                m = medians([x for x, _ in pts], [y for _, y in pts])
                ax.plot([x for x, _ in m], [y for _, y in m], color=colour, lw=2, label=None if k else f"{name}, median")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("Euclidean distance (m); touching pairs <= 1e-6")
    ax.set_ylabel("time per pair (µs)")
    ax.set_title(f"{len(rows)} pairs: separated and touching")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    if overlap:
        ax_o.boxplot(
            [[float(r["fcl_us"]) for r in overlap], [float(r["gap_us"]) for r in overlap]],
            labels=["FCL", "GAP"],
            showfliers=False,
        )
    ax_o.set_title(f"overlapping ({len(overlap)})")
    fig.tight_layout()
    fig.savefig(argv[2], dpi=120)


if __name__ == "__main__":
    main(sys.argv)
