#!/usr/bin/env python3
"""Whether the Newton rounds pay, by Bond number: protocol A scans run with Newton rounds
(`solver.newton_every = 5`) and without (`solver.newton_every = 0`, NNCG alone), the same members
each way. The program's default takes the rounds from Bo = 200 on (`default_newton_every`).

    /usr/bin/python3 bench/newton_by_bond.py [--bond 0,10,100,300,1000] [--width 24]
                                             [--height 48] [--seeds 16] [--out DIR]
                                             [--program build/loosepack]

For every Bond number, runs the two scans one after the other on one core (scan seed 41, the
time step the program chooses) and prints one JSON line each: user CPU seconds of the run, its
steps and sweeps, nu_lower_half and mean abs(Delta y) with their standard errors, and, on the
second line, the CPU ratio (NNCG alone over the rounds'; > 1: the rounds pay) and the
difference of nu_lower_half over the paired members in units of its standard error. Runs
already in --out are read, not re-run (their CPU is then the one recorded beside them).
docs/PERFORMANCE.md, "Newton steps", cites the record.
"""
import argparse
import json
import math
import os
import resource
import subprocess
import sys

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
from sensitivity import environment  # noqa: E402
from loosepack.runner import to_toml  # noqa: E402


def run(program, scan, path):
    """Runs `scan` into `path` unless there; returns its user CPU seconds (kept beside it)."""
    cpu_path = path + ".cpu"
    if not os.path.exists(path):
        with open(path[:-3] + ".toml", "w") as f:
            f.write(to_toml(scan))
        before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
        subprocess.run([program, "run", path[:-3] + ".toml", "-o", path, "-q"], check=True)
        with open(cpu_path, "w") as f:
            f.write(str(resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime - before))
    with open(cpu_path) as f:
        return float(f.read())


def measured(path, cpu):
    with h5py.File(path, "r") as f:
        m = f["points/0000/members"]
        a = f["points/0000"].attrs
        return {"user_cpu_s": cpu, "steps": int(m["steps"][()].sum()),
                "sweeps": int(m["sweeps"][()].sum()), "failed": int((m["failure"][()] != 0).sum()),
                "nu_lower_half": [float(a["nu_lower_half_mean"]), float(a["nu_lower_half_sem"])],
                "mean_abs_dy": [float(a["mean_abs_dy_mean"]), float(a["mean_abs_dy_sem"])],
                "nu_members": m["nu_lower_half"][()]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bond", default="0,10,100,300,1000")
    ap.add_argument("--width", type=float, default=24.0)
    ap.add_argument("--height", type=float, default=48.0)
    ap.add_argument("--seeds", type=int, default=16)
    ap.add_argument("--out", default="out/newton_by_bond")
    ap.add_argument("--program", default=os.path.join(os.path.dirname(__file__), "..", "build",
                                                      "loosepack"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    env = environment()
    for bo in [float(b) for b in args.bond.split(",")]:
        rows = {}
        for name, solver in (("rounds", {"newton_every": 5}), ("nncg_alone", {"newton_every": 0})):
            scan = {"scan": {"name": f"newton_{name}", "seed": 41, "seeds": args.seeds,
                             "protocol": "A"},
                    "system": {"width": args.width, "height": args.height, "bond_number": bo}}
            scan["solver"] = solver
            path = os.path.join(args.out, f"bo{bo:g}_{name}.h5")
            rows[name] = measured(path, run(args.program, scan, path))
        dnu = rows["nncg_alone"]["nu_members"] - rows["rounds"]["nu_members"]
        paired = float(dnu.mean() / (dnu.std(ddof=1) / math.sqrt(len(dnu)))) \
            if dnu.std(ddof=1) > 0 else 0.0
        for name, r in rows.items():
            r.pop("nu_members")
            line = {"study": "newton_by_bond", "variant": name, "bond_number": bo,
                    "width": args.width, "height": args.height, "seeds": args.seeds, **r, **env}
            if name == "nncg_alone":
                line["cpu_ratio_nncg_over_rounds"] = r["user_cpu_s"] / rows["rounds"]["user_cpu_s"]
                line["nu_lower_half_paired_difference_in_errors"] = paired
            print(json.dumps(line), flush=True)


if __name__ == "__main__":
    main()
