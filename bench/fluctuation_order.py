#!/usr/bin/env python3
"""The deposition density's fluctuation at y = 200 pooled over runs (docs/REPRODUCTION.md, claim
16): each member's fluctuation (`tools/claims.py`, member_fluctuations) from the protocol-A points
at Bo = 1e2 and 1e3 of every result file given, pooled by Bond number over the points of one box
(width, height and the other system parameters equal; independent members: files of other scan
seeds or other points), then judged as `tools/claims.py` judges one file's: Bo = 1e3 fluctuates
more than 1e2 when their ratio lies above one by more than t95 of its error (the fewer members').

    /usr/bin/python3 bench/fluctuation_order.py RESULT.h5 [MORE.h5 ...] [--json]

Prints each point's members and value, each box's pooled values and the verdict (with --json one
JSON line a box instead). Exits 2 on unusable input: a file that cannot be read, or no box with
both Bond numbers.
"""
import argparse
import contextlib
import json
import os
import sys

import h5py
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
import claims  # noqa: E402


def unusable(message):
    print(f"fluctuation_order.py: {message}", file=sys.stderr)
    sys.exit(2)


def runs_by_box(paths):
    """claims.fluctuations_by_box over every point of the files, each labelled "FILE POINT"."""
    with contextlib.ExitStack() as files:
        try:
            points = []
            for path in paths:
                f = files.enter_context(h5py.File(path, "r"))
                points += [(f"{path} {name}", f["points"][name]) for name in sorted(f["points"])]
            return claims.fluctuations_by_box(points)
        except (OSError, KeyError) as e:
            unusable(f"{path}: {e}")


def pooled(runs):
    """{mean, sem, members} of the members of every run (claims.fluctuation_summary)."""
    summary = claims.fluctuation_summary([v for _, rel in runs for v in rel])
    return dict(zip(("mean", "sem", "members"), summary))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("files", nargs="+")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    judged = 0
    for box, by_bo in runs_by_box(args.files).items():
        if len(by_bo) < 2:
            continue
        judged += 1
        ok, detail = claims.fluctuation_order(by_bo)
        size = dict(box)
        if args.json:
            print(json.dumps({
                "box": size, "holds": bool(ok), "detail": detail,
                "points": {f"{bo:g}": [{"point": label, "members": rel} for label, rel in runs]
                           for bo, runs in by_bo.items()},
                "pooled": {f"{bo:g}": pooled(runs) for bo, runs in by_bo.items()}}))
            continue
        print(f"box {size['width']:g} R x {size['height']:g} R")
        for bo, runs in sorted(by_bo.items()):
            for label, rel in runs:
                print(f"  Bo = {bo:g}  {label}: {len(rel)} members, "
                      f"{np.mean(rel):.1%} ({', '.join(f'{v:.1%}' for v in rel)})")
        print(f"  Bo = 1e3 fluctuates more than 1e2: {'holds' if ok else 'not shown'}; {detail}")
    if not judged:
        unusable("no box holds protocol-A points at both Bo = 1e2 and 1e3 that reach 220 R")


if __name__ == "__main__":
    main()
