#!/usr/bin/env python3
"""How close the contacts of deposits at rest are to their bounds (docs/MODEL.md, "Contact law").

    bench/contact_mobilisation.py OUT.h5 [--json FILE --label LABEL]

reads every snapshot of a result file written with `loosepack run --snapshots` and prints, per
snapshot, the mobilisation of each bound: tangential |F_t| / (mu (F_n + F_c)), rolling |M| /
(mu_r R_c (F_n + F_c)) with R_c = min(R_i, R_j) (R_i on the floor), and tension -F_n / F_c; their
quantiles and the contacts within 1 % and 10 % of the bound. A contact on its bound is where a
structure at rest may start to slide, roll or open. docs/PERFORMANCE.md ("Where a tall cohesive
deposit's steps go") uses it to ask whether saturated contacts could tell a static check which
part of a deposit can move.
"""

import argparse
import json
import sys

import h5py
import numpy as np

QUANTILES = (0.5, 0.9, 0.99)


def mobilisation(snapshot, friction, rolling_friction, cohesive_force):
    """The three mobilisations of every contact of one snapshot group."""
    r = snapshot["radius"][()]
    i = snapshot["contact_i"][()]
    j = snapshot["contact_j"][()]
    fn = snapshot["contact_normal"][()]
    reach = fn + cohesive_force
    rc = np.where(j >= 0, np.minimum(r[i], r[np.maximum(j, 0)]), r[i])
    with np.errstate(divide="ignore", invalid="ignore"):
        tangential = np.abs(snapshot["contact_tangential"][()]) / (friction * reach)
        rolling = np.abs(snapshot["contact_moment"][()]) / (rolling_friction * rc * reach)
    tension = -fn / cohesive_force if cohesive_force > 0 else np.zeros_like(fn)
    return {"tangential": tangential, "rolling": rolling, "tension": tension}


def summarise(ratios):
    out = {"contacts": int(len(ratios["rolling"]))}
    for name, x in ratios.items():
        x = np.nan_to_num(x, nan=0.0)
        out[name] = {
            "quantiles": [float(q) for q in np.quantile(x, QUANTILES)] if len(x) else [],
            "within_1_percent": int((x > 0.99).sum()),
            "within_10_percent": int((x > 0.9).sum()),
        }
    return out


def snapshots(path):
    """(point name, snapshot name, the point's attributes, snapshot group) of every snapshot."""
    f = h5py.File(path, "r")
    for point_name, point in f["points"].items():
        for name, group in point["members"].items():
            if name.startswith("snapshot_"):
                yield point_name, name, dict(point.attrs), group


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("result", help="result file written with --snapshots")
    ap.add_argument("--json", help="append one line per snapshot to this file")
    ap.add_argument("--label", default="", help="label of the JSON lines")
    a = ap.parse_args(argv)
    lines = []
    for point_name, name, attrs, group in snapshots(a.result):
        s = summarise(mobilisation(group, attrs["friction"], attrs["rolling_friction"],
                                   attrs["cohesive_force"]))
        s.update({"point": point_name, "snapshot": name, "label": a.label, "file": a.result})
        lines.append(s)
        print(f"{point_name}/{name}: {s['contacts']} contacts")
        for bound in ("tangential", "rolling", "tension"):
            b = s[bound]
            qs = " ".join(f"{q:.3f}" for q in b["quantiles"])
            print(f"  {bound:10s} quantiles 50/90/99 %: {qs}; within 1 % of the bound: "
                  f"{b['within_1_percent']}, within 10 %: {b['within_10_percent']}")
    if not lines:
        sys.exit(f"{a.result}: no snapshots (run with --snapshots)")
    if a.json:
        with open(a.json, "a") as out:
            for s in lines:
                out.write(json.dumps(s) + "\n")


if __name__ == "__main__":
    main()
