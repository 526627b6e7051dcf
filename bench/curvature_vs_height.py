#!/usr/bin/env python3
"""Fig. 7's question in one picture (docs/REPRODUCTION.md, "The tall runs" and "At the paper's
width"): the curvature c of Delta y(y_i) and of Delta y(y_e) against the box's height H, log-log,
with lines of c ~ 1/H. The 40 R wide series are bench/height_exponents.py's (Bo = 1e3 with the
default stop rule and the present program's H = 400 point beside its own; Bo = 1e2); the width
pairs are bench/width_factor.py's (a box 100 R or 200 R wide and a 40 R box of the same settings
with the paper's stop rule, at one height); the paper's own curvatures (figs. 6 and 11, its
200 R x 800 R box) are stars. Each point is an ensemble's fit with its jackknife error.

    /usr/bin/python3 bench/curvature_vs_height.py OUT.png

The 1/H lines pass through each Bond number's tallest 40 R point, so a series that falls like
1/H runs parallel to them.
"""
import argparse
import glob
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import height_exponents  # noqa: E402  (the 40 R series' tables)
import width_factor  # noqa: E402  (the width pairs)

CURVATURES = {"Delta y(y_i): c": "c of Delta y(y_i) [1e-4]",
              "Delta y(y_e): c": "c of Delta y(y_e) [1e-4]"}
# The paper's curvatures [1e-4] at H = 800: the fits of its figs. 6 (Bo = 1e3) and 11 (1e2).
PAPER = {1000.0: {"Delta y(y_i): c": 3.5, "Delta y(y_e): c": 3.8},
         100.0: {"Delta y(y_i): c": 5.6, "Delta y(y_e): c": 5.9}}
PAPER_HEIGHT = 800.0


def narrow_series():
    """The 40 R wide series, each {bond, label, heights, members, values: {curvature: (values,
    errors) in 1e-4}} (bench/height_exponents.py's tables)."""
    present = height_exponents.h400_present_table()
    out = []
    for bond, key, label in ((1000.0, "1e3", "Bo = 1e3, 40 R"), (100.0, "1e2", "Bo = 1e2, 40 R")):
        series = height_exponents.SERIES[key]
        table = series["table"]()
        out.append({"bond": bond, "label": label, "heights": list(series["heights"]),
                    "members": list(series["members"]),
                    "values": {q: table[name] for q, name in CURVATURES.items()}})
    h400 = height_exponents.SERIES["1e3-h400-2026-12-07"]
    out.append({"bond": 1000.0, "label": "Bo = 1e3, 40 R, H = 400 again (16 members)",
                "heights": [h400["heights"][0]], "members": [h400["members"][0]],
                "values": {q: ([present[name][0][0]], [present[name][1][0]])
                           for q, name in CURVATURES.items()}})
    return out


def pair_points(paths):
    """The width pairs' points, each {bond, width, height, members, curvature: (value, error) in
    1e-4}: a wide box's and its 40 R partner's (the paper's stop rule both), each ensemble once."""
    out = []
    for (bond, wide, height), pair in sorted(width_factor.pairs(paths).items()):
        for side, width in enumerate((wide, 40.0)):
            point = {"bond": bond, "width": width, "height": height,
                     "members": pair["members"][side]}
            for q in CURVATURES:
                value, error = pair["values"][q][side]
                point[q] = (value * 1e4, error * 1e4)
            if point not in out:  # a 40 R ensemble that partners two wide boxes: once
                out.append(point)
    return out


def one_over_h(heights, anchor_height, anchor_value):
    """c ~ 1/H through (anchor_height, anchor_value), at each of `heights`."""
    return [anchor_value * anchor_height / h for h in heights]


def draw(out_path, narrow, pairs):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colour = {1000.0: "C0", 100.0: "C1"}
    bond_name = {1000.0: "1e3", 100.0: "1e2"}
    marker = {40.0: "D", 100.0: "s", 200.0: "^"}
    fig, axes = plt.subplots(1, 2, figsize=(11, 5.6), sharey=True)
    for ax, q in zip(axes, CURVATURES):
        for s in narrow:
            values, errors = s["values"][q]
            again = len(s["heights"]) == 1
            ax.errorbar(s["heights"], values, yerr=errors, fmt="o", color=colour[s["bond"]],
                        mfc="white" if again else colour[s["bond"]], capsize=2, label=s["label"])
            if not again:
                span = [min(s["heights"]) * 0.9, PAPER_HEIGHT * 1.1]
                ax.plot(span, one_over_h(span, s["heights"][-1], values[-1]), "--",
                        color=colour[s["bond"]], lw=0.8)
        for width in sorted({p["width"] for p in pairs}):
            for bond in sorted({p["bond"] for p in pairs}, reverse=True):
                points = [p for p in pairs if p["width"] == width and p["bond"] == bond]
                if not points:
                    continue
                ax.errorbar([p["height"] * (1.03 if width > 40 else 0.97) for p in points],
                            [p[q][0] for p in points], yerr=[p[q][1] for p in points],
                            fmt=marker[width], color=colour[bond], mfc="none", capsize=2, ms=6,
                            label=f"Bo = {bond_name[bond]}, {width:g} R, the paper's stop rule "
                                  "(width pairs)")
        for bond, values in PAPER.items():
            ax.plot([PAPER_HEIGHT], [values[q]], "*", color=colour[bond], ms=13, mec="k",
                    alpha=0.6, zorder=1, label=f"Bo = {bond_name[bond]}, the paper (200 R x 800 R)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks([100, 200, 400, 800])
        ax.set_xticklabels(["100", "200", "400", "800"])
        ax.set_yticks([3, 5, 10, 20, 30])
        ax.set_yticklabels(["3", "5", "10", "20", "30"])
        ax.set_xlabel("H [R]")
        ax.set_title(q.replace(": c", "") + ": curvature c")
        ax.grid(True, which="both", lw=0.3)
    axes[0].set_ylabel("c [1e-4 / R]")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=7.5)
    fig.suptitle("Avalanche profile curvature against height (dashed: c ~ 1/H)", fontsize=10)
    fig.tight_layout(rect=(0, 0.17, 1, 1))
    fig.savefig(out_path, dpi=130)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out", help="the PNG to write")
    args = parser.parse_args()
    paths = sorted(glob.glob(os.path.join(width_factor.RESULTS, "paper-width-A-*.jsonl")))
    narrow, pairs = narrow_series(), pair_points(paths)
    for s in narrow:
        cells = ", ".join(f"{h:g}: {v:.2f} +- {e:.2f}" for h, v, e in
                          zip(s["heights"], *s["values"]["Delta y(y_e): c"]))
        print(f"{s['label']}, c of Delta y(y_e) [1e-4] at H = {cells}")
    for p in pairs:
        print(f"Bo = {p['bond']:g}, {p['width']:g} R x {p['height']:g} R ({p['members']} members): "
              f"c of Delta y(y_e) {p['Delta y(y_e): c'][0]:.2f} +- {p['Delta y(y_e): c'][1]:.2f}")
    draw(args.out, narrow, pairs)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
