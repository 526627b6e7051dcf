#!/usr/bin/env python3
"""How the paper's width changes the avalanche profile's curvature (docs/REPRODUCTION.md, "At the
paper's width"): from the width pairs' records (bench/results/paper-width-A-*.jsonl, written by
`tools/compare.py --json`, a wide box as A against a 40 R box as B at one height), the ratio of
the curvature c of Delta y(y_i) and of Delta y(y_e), wide over narrow, at each height; then for
each Bond number and wide width, the ratios' weighted mean with its chi2 against a constant, and
the power of H in the ratio, ln(ratio) against ln H, weighted: the amount by which the width
changes the exponent of H in c (0 if the width scales c by a constant factor).

    /usr/bin/python3 bench/width_factor.py [--json bench/results/FILE.jsonl]

A ratio's error is first order in the two relative errors (each a jackknife over its members;
with two members it is itself uncertain by about 70 %). Where several records hold one height,
the one of most wide members is taken, then of most narrow members, then the latest.
"""
import argparse
import datetime
import glob
import json
import math
import os
import re
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
from compare import ratio  # noqa: E402  (A/B and its first-order error, as compare.py gives it)

RESULTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results")
CURVATURES = ("Delta y(y_i): c", "Delta y(y_e): c")


def point_of(text):
    """(Bond number, width, height, members) of compare.py's description of a point."""
    number = lambda key: float(re.search(rf"{key} ([0-9.e+-]+)", text).group(1))
    return number("bond_number"), number("width"), number("height"), int(number("members"))


def value_of(row, side):
    """A row's value and error on side 'a' or 'b': its numbers, or the text of older records."""
    if row.get(f"{side}_value") is not None:
        return row[f"{side}_value"], row[f"{side}_error"]
    v, e = row[side].split("+-")
    return float(v), float(e)


def pairs(paths):
    """Each width pair of the records, keyed by (Bond number, wide width, height): the wide and
    narrow members, the record's file and date, each curvature's (value, error) wide and narrow,
    and its ratio wide / narrow with its error (compare.py's `ratio`)."""
    out = {}
    rank = lambda p: (p["members"], p["date"])  # most wide members, then narrow, then latest
    for path in paths:
        date = re.search(r"(\d{4}-\d\d-\d\d)", os.path.basename(path)).group(1)
        with open(path) as f:
            for line in f:
                record = json.loads(line)
                bond, wide, height, wide_members = point_of(record["a_point"])
                _, narrow, _, narrow_members = point_of(record["b_point"])
                rows = {r["quantity"]: r for r in record["rows"]}
                if narrow != 40.0 or not all(q in rows for q in CURVATURES):
                    continue
                values = {q: (value_of(rows[q], "a"), value_of(rows[q], "b")) for q in CURVATURES}
                pair = {"members": (wide_members, narrow_members), "date": date,
                        "record": os.path.basename(path), "values": values,
                        "ratio": {q: ratio(*wide, *narrow) for q, (wide, narrow) in values.items()}}
                if not all(pair["ratio"].values()):
                    continue  # a narrow curvature not resolved from 0: no ratio to take
                key = (bond, wide, height)
                if key not in out or rank(pair) >= rank(out[key]):
                    out[key] = pair
    return out


def constant_and_power(heights, ratios, errors):
    """The ratios' weighted mean and its error, chi2 against it and its degrees of freedom, and
    the weighted slope of ln(ratio) against ln H with its error (None for one height). Both in
    ln(ratio), whose error e/r does not grow with the ratio: a linear mean weighted by 1/e^2,
    with e proportional to r, would favour the lower ratios."""
    r, e = np.array(ratios), np.array(errors)
    x, y, wl = np.log(heights), np.log(r), (r / e) ** 2
    log_mean = float((wl * y).sum() / wl.sum())
    mean = math.exp(log_mean)
    chi2 = float((wl * (y - log_mean) ** 2).sum())
    if len(r) < 2:
        return mean, mean * float(wl.sum() ** -0.5), chi2, 0, None
    a = np.vstack([np.ones_like(x), x]).T
    cov = np.linalg.inv(a.T @ (a * wl[:, None]))
    slope = (cov @ (a.T @ (wl * y)))[1]
    return (mean, mean * float(wl.sum() ** -0.5), chi2, len(r) - 1,
            (float(slope), math.sqrt(cov[1, 1])))


def series(pairs_by_key):
    """Per (Bond number, wide width): each height's ratios, and each curvature's constant and
    power of H (constant_and_power)."""
    out = {}
    for (bond, wide, height), pair in sorted(pairs_by_key.items()):
        s = out.setdefault((bond, wide), {"heights": [], "pairs": [], "ratios": {}})
        s["heights"].append(height)
        s["pairs"].append(pair)
        for q in CURVATURES:
            s["ratios"].setdefault(q, []).append(pair["ratio"][q])
    for s in out.values():
        s["fits"] = {q: constant_and_power(s["heights"], [v for v, _ in rs], [e for _, e in rs])
                     for q, rs in s["ratios"].items()}
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", help="append one JSON line per series to this file")
    args = parser.parse_args()
    paths = sorted(glob.glob(os.path.join(RESULTS, "paper-width-A-*.jsonl")))
    commit = subprocess.run(["git", "describe", "--always", "--dirty"], capture_output=True,
                            text=True, cwd=RESULTS).stdout.strip()
    for (bond, wide), s in series(pairs(paths)).items():
        print(f"Bo = {bond:g}, {wide:g} R against 40 R wide:")
        for k, height in enumerate(s["heights"]):
            pair = s["pairs"][k]
            cells = "; ".join(f"{q[:-3]} {s['ratios'][q][k][0]:.3f} +- {s['ratios'][q][k][1]:.3f}"
                              for q in CURVATURES)
            print(f"  H = {height:g} ({pair['members'][0]} and {pair['members'][1]} members, "
                  f"{pair['record']}): c wide / narrow, {cells}")
        for q, (mean, error, chi2, dof, power) in s["fits"].items():
            line = f"  {q[:-3]}: weighted mean {mean:.3f} +- {error:.3f}, chi2 {chi2:.1f} for {dof}"
            if power:
                line += f"; ratio ~ H^({power[0]:.3f} +- {power[1]:.3f})"
            print(line)
        if args.json:
            record = {"study": f"width factor of the curvature, Bo = {bond:g}, {wide:g} R against "
                               "40 R wide", "date": datetime.date.today().isoformat(),
                      "commit": commit, "heights": s["heights"],
                      "records": [p["record"] for p in s["pairs"]],
                      "members": [p["members"] for p in s["pairs"]],
                      "ratios": s["ratios"],
                      "fits": {q: {"mean": f[0], "error": f[1], "chi2": f[2], "dof": f[3],
                                   "power_of_H": f[4]} for q, f in s["fits"].items()}}
            with open(args.json, "a") as f:
                f.write(json.dumps(record) + "\n")


if __name__ == "__main__":
    main()
