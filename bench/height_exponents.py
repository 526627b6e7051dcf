#!/usr/bin/env python3
"""The exponents of H in docs/REPRODUCTION.md, "The tall runs": weighted power laws through the
curvatures c of Delta y(y_i) and Delta y(y_e) and the slice model's a at H = 120 to 800, over the
spans of heights the table names, fitted as the program fits across the points of one file
(docs/OUTPUT.md, "Fits across points"): ln y against ln H, each height's error sigma/y widened by
sqrt((n - 1)/(n - 3)) for its n members, the exponent's error scaled by sqrt(chi2/dof) where that
exceeds 1.

    /usr/bin/python3 bench/height_exponents.py [--json bench/results/height-exponents-DATE.jsonl]

The values are the table's (each height's ensemble, with its jackknife error), from the records
RECORDS names.
"""
import argparse
import datetime
import json
import math
import subprocess

import numpy as np

HEIGHTS = (120, 180, 240, 300, 400, 800)
MEMBERS = (16, 16, 16, 16, 8, 4)
RECORDS = ("relative-tolerance-2026-11-25.jsonl (H = 120 to 240: its relative_tolerance = 1e-3 rows)",
           "tall-A-H300-2026-11-25.jsonl",
           "tall-A-H400-2026-11-26.jsonl", "tall-A-H800-2026-11-26.jsonl")
# Each quantity's value and error at the heights above.
TABLE = {
    "c of Delta y(y_i) [1e-4]": ((11.5, 12.0, 10.6, 9.9, 8.25, 3.97),
                                 (1.9, 1.2, 0.6, 0.4, 0.47, 0.13)),
    "c of Delta y(y_e) [1e-4]": ((12.4, 12.4, 10.9, 10.1, 8.40, 3.90),
                                 (2.0, 1.2, 0.7, 0.5, 0.43, 0.18)),
    "slice model a": ((0.113, 0.184, 0.235, 0.275, 0.320, 0.335),
                      (0.016, 0.018, 0.013, 0.010, 0.013, 0.007)),
}
SPANS = ((120, 300), (120, 400), (240, 400), (400, 800), (120, 800))


def exponent(values, errors, low, high):
    """(p, its error, chi2/dof or None) of y = A H^p over the heights in [low, high]."""
    use = [k for k, h in enumerate(HEIGHTS) if low <= h <= high]
    x = np.log([HEIGHTS[k] for k in use])
    y = np.log([values[k] for k in use])
    sigma = np.array([errors[k] / values[k] * math.sqrt((MEMBERS[k] - 1) / (MEMBERS[k] - 3))
                      for k in use])
    w = 1.0 / sigma ** 2
    a = np.vstack([np.ones_like(x), x]).T
    cov = np.linalg.inv(a.T @ (a * w[:, None]))
    coef = cov @ (a.T @ (w * y))
    dof = len(use) - 2
    chi2 = float((w * (y - a @ coef) ** 2).sum())
    scale = math.sqrt(chi2 / dof) if dof > 0 and chi2 / dof > 1 else 1.0
    return float(coef[1]), math.sqrt(cov[1, 1]) * scale, (chi2 / dof if dof > 0 else None)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", help="append the exponents as one JSON line to this file")
    args = parser.parse_args()
    commit = subprocess.run(["git", "describe", "--always", "--dirty"], capture_output=True,
                            text=True).stdout.strip()
    record = {"study": "height exponents", "date": datetime.date.today().isoformat(),
              "commit": commit, "records": RECORDS, "exponents": {}}
    for name, (values, errors) in TABLE.items():
        cells = []
        for low, high in SPANS:
            p, e, reduced = exponent(values, errors, low, high)
            record["exponents"].setdefault(name, {})[f"{low}-{high}"] = [p, e, reduced]
            cells.append(f"{low}-{high}: {p:.2f} +- {e:.2f}" +
                         (f" (chi2/dof {reduced:.1f})" if reduced is not None else ""))
        print(f"{name}: " + "; ".join(cells))
    if args.json:
        with open(args.json, "a") as f:
            f.write(json.dumps(record) + "\n")


if __name__ == "__main__":
    main()
