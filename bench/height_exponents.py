#!/usr/bin/env python3
"""The exponents of H in docs/REPRODUCTION.md, "The tall runs" (Bo = 1e3) and row 14 (Bo = 1e2):
weighted power laws through the curvatures c of Delta y(y_i) and Delta y(y_e) and the slice
model's a, 40 R wide, over the spans of heights each series names, fitted as the program fits
across the points of one file (docs/OUTPUT.md, "Fits across points"): ln y against ln H, each
height's error sigma/y widened by sqrt((n - 1)/(n - 3)) for its n members, the exponent's error
scaled by sqrt(chi2/dof) where that exceeds 1.

    /usr/bin/python3 bench/height_exponents.py [--bond 1e3|1e2] [--json bench/results/FILE.jsonl]

The values are each height's ensemble with its jackknife error, from the records each series
names (the Bo = 1e3 ones as a table, the Bo = 1e2 ones read from their records).
"""
import argparse
import datetime
import json
import math
import os
import subprocess

import numpy as np


def bo1e2_table():
    """The Bo = 1e2 series' values and errors, as its records hold them: the fits' curvatures (in
    1e-4) and the slice model's a at H = 120, 180, 240 (one scan) and 400."""
    results = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results")
    with open(os.path.join(results, "bo1e2-heights-2026-12-06.jsonl")) as f:
        scan = json.loads(f.readline())
    with open(os.path.join(results, "bo1e2-H400-regions-2026-12-06.jsonl")) as f:
        h400 = [json.loads(line) for line in f][1]
    points = scan["points"] + [h400]
    slice_a = scan["slice_a"] + [h400["slice_a"]]

    def curvature(fit):
        return ([p[fit]["coef"][2] * 1e4 for p in points],
                [p[fit]["error"][2] * 1e4 for p in points])

    return {"c of Delta y(y_i) [1e-4]": curvature("fit_yi"),
            "c of Delta y(y_e) [1e-4]": curvature("fit_ye"),
            "slice model a": ([a for a, _ in slice_a], [e for _, e in slice_a])}


def h400_present_table():
    """Bo = 1e3 from H = 400 to 800 with the present program's H = 400 point (16 members,
    tall-A-H400-2026-12-07.jsonl, jackknife errors) and the H = 800 point of the "1e3" series."""
    results = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results")
    with open(os.path.join(results, "tall-A-H400-2026-12-07.jsonl")) as f:
        h400 = json.loads(f.readline())
    at_400 = {"c of Delta y(y_i) [1e-4]": [c * 1e4 for c in
                                           (h400["fit_yi"]["coef"][2], h400["fit_yi"]["error"][2])],
              "c of Delta y(y_e) [1e-4]": [c * 1e4 for c in
                                           (h400["fit_ye"]["coef"][2], h400["fit_ye"]["error"][2])],
              "slice model a": h400["slice_a"]}
    at_800 = SERIES["1e3"]["heights"].index(800)
    return {name: ((at_400[name][0], values[at_800]), (at_400[name][1], errors[at_800]))
            for name, (values, errors) in SERIES["1e3"]["table"]().items()}


# Each series: its heights, members per height, records, each quantity's values and errors at
# those heights (a function that gives them), and the spans of heights fitted.
SERIES = {
    "1e3": {
        "heights": (120, 180, 240, 300, 400, 800),
        "members": (16, 16, 16, 16, 8, 4),
        "records": ("relative-tolerance-2026-11-25.jsonl (H = 120 to 240: its "
                    "relative_tolerance = 1e-3 rows)", "tall-A-H300-2026-11-25.jsonl",
                    "tall-A-H400-2026-11-26.jsonl", "tall-A-H800-2026-11-26.jsonl"),
        "table": lambda: {
            "c of Delta y(y_i) [1e-4]": ((11.5, 12.0, 10.6, 9.9, 8.25, 3.97),
                                         (1.9, 1.2, 0.6, 0.4, 0.47, 0.13)),
            "c of Delta y(y_e) [1e-4]": ((12.4, 12.4, 10.9, 10.1, 8.40, 3.90),
                                         (2.0, 1.2, 0.7, 0.5, 0.43, 0.18)),
            "slice model a": ((0.113, 0.184, 0.235, 0.275, 0.320, 0.335),
                              (0.016, 0.018, 0.013, 0.010, 0.013, 0.007)),
        },
        "spans": ((120, 300), (120, 400), (240, 400), (400, 800), (120, 800)),
    },
    "1e3-h400-2026-12-07": {
        "heights": (400, 800),
        "members": (16, 4),
        "records": ("tall-A-H400-2026-12-07.jsonl", "tall-A-H800-2026-11-26.jsonl"),
        "table": h400_present_table,
        "spans": ((400, 800),),
    },
    "1e2": {
        "heights": (120, 180, 240, 400),
        "members": (4, 4, 4, 4),
        "records": ("bo1e2-heights-2026-12-06.jsonl (H = 120 to 240)",
                    "bo1e2-H400-regions-2026-12-06.jsonl (its second line)"),
        "table": bo1e2_table,  # read from the records
        "spans": ((120, 240), (240, 400), (120, 400)),
    },
}


def exponent(series, values, errors, low, high):
    """(p, its error, chi2/dof or None) of y = A H^p over the series' heights in [low, high].
    As the program fits across points: each error widened by sqrt((n-1)/(n-3)) for its n
    members, and the fit's error scaled by sqrt(chi2/dof) where that exceeds 1; a point of 3
    members or fewer keeps its error as estimated and leaves the fit without a chi2 to judge
    (None)."""
    heights, members = series["heights"], series["members"]
    use = [k for k, h in enumerate(heights) if low <= h <= high]
    few = any(members[k] <= 3 for k in use)
    x = np.log([heights[k] for k in use])
    y = np.log([values[k] for k in use])
    widen = lambda n: math.sqrt((n - 1) / (n - 3)) if n > 3 else 1.0
    sigma = np.array([errors[k] / values[k] * widen(members[k]) for k in use])
    w = 1.0 / sigma ** 2
    a = np.vstack([np.ones_like(x), x]).T
    cov = np.linalg.inv(a.T @ (a * w[:, None]))
    coef = cov @ (a.T @ (w * y))
    dof = len(use) - 2
    chi2 = float((w * (y - a @ coef) ** 2).sum())
    scale = math.sqrt(chi2 / dof) if dof > 0 and chi2 / dof > 1 else 1.0
    return float(coef[1]), math.sqrt(cov[1, 1]) * scale, (chi2 / dof if dof > 0 and not few
                                                          else None)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--bond", choices=sorted(SERIES), action="append",
                        help="the series of this Bond number (default: every one)")
    parser.add_argument("--json", help="append the exponents as one JSON line per series to this "
                        "file")
    args = parser.parse_args()
    commit = subprocess.run(["git", "describe", "--always", "--dirty"], capture_output=True,
                            text=True).stdout.strip()
    for bond in args.bond or sorted(SERIES):
        series = SERIES[bond]
        record = {"study": f"height exponents, Bo = {bond}",
                  "date": datetime.date.today().isoformat(), "commit": commit,
                  "records": series["records"], "exponents": {}}
        print(f"Bo = {bond}, H = {', '.join(map(str, series['heights']))}:")
        for name, (values, errors) in series["table"]().items():
            cells = []
            for low, high in series["spans"]:
                p, e, reduced = exponent(series, values, errors, low, high)
                record["exponents"].setdefault(name, {})[f"{low}-{high}"] = [p, e, reduced]
                cells.append(f"{low}-{high}: {p:.2f} +- {e:.2f}" +
                             (f" (chi2/dof {reduced:.1f})" if reduced is not None else ""))
            print(f"  {name}: " + "; ".join(cells))
        if args.json:
            with open(args.json, "a") as f:
                f.write(json.dumps(record) + "\n")


if __name__ == "__main__":
    main()
