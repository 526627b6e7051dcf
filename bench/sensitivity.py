#!/usr/bin/env python3
"""How far the results move under the model choices the paper does not fix.

    /usr/bin/python3 bench/sensitivity.py [--scene bo1e2|bo1e3] [--seeds N] [--out DIR]
                                          [--program build/loosepack] [--only NAME,...]

Runs one protocol-A scene once as the program's defaults have it and once per variant of one
choice (docs/REPRODUCTION.md, "Sensitivity to the model's choices"), every run with the same
scan seed, so member k of every variant starts from the same random drops; then prints one row
per variant: nu_lower_half, the curvature c2 of Delta y(y_e) in the band between the cuts (the
fit of tools/claims.py: unweighted, jackknife errors), whether tools/claims.py's parabola claim
holds there, mean |Delta y|, the cut |Delta y| histogram's verdict, and each quantity's
difference from the defaults in units of the jackknife error of that difference over the paired
members (what a variant does to the same members). Runs already in --out are read, not re-run,
so an interrupted study goes on where it stopped. Writes a JSON-lines record per variant to
--out/sensitivity.jsonl.

Scenes: bo1e2 is A at Bo = 1e2, 24 R x 48 R (the reduced claim file's parabola point; about 30 s
per variant for 16 members); bo1e3 is A at Bo = 1e3, 40 R x 120 R with the tall files' regions
and tolerance (about 5 minutes per variant for 16 members on one core).
"""
import argparse
import datetime
import json
import math
import os
import subprocess
import sys

import h5py
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
from claims import Profile, jackknife, parabola_verdict  # noqa: E402
from loosepack.runner import to_toml  # noqa: E402

SCENES = {
    "bo1e2": {
        "scan": {"name": "sensitivity_bo1e2", "seed": 2026, "protocol": "A"},
        "system": {"width": 24, "height": 48, "bond_number": 100},
        "observables": {"lower_half_from": 4.0, "cut_bottom": 4.0, "cut_top": 4.0},
    },
    "bo1e3": {
        "scan": {"name": "sensitivity_bo1e3", "seed": 2011, "protocol": "A"},
        "system": {"width": 40, "height": 120, "bond_number": 1000},
        "solver": {"tolerance": 3e-3},
        "protocol": {"region_radius": 8, "region_check_every": 10},
        "observables": {"cut_bottom": 8.0, "cut_top": 8.0},
    },
}

# (name, section, key, value): one choice changed at a time.
VARIANTS = [
    ("defaults", None, None, None),
    ("cohesion_range 0.005", "system", "cohesion_range", 0.005),
    ("cohesion_range 0.02", "system", "cohesion_range", 0.02),
    ("floor_cohesion off", "system", "floor_cohesion", False),
    ("rest.speed 3e-3", "rest", "speed", 3e-3),
    ("max_relax_time 100", "protocol", "max_relax_time", 100.0),
    ("stop_rule no_room", "protocol", "stop_rule", "no_room"),
    # A quarter of the default time step (0.009 at Bo = 1e2, 0.00285 at 1e3): the pull-off
    # threshold's first-order error a h / 2 (docs/VALIDATION.md, case 6) is 0.45 v* at the
    # default h and 0.11 v* here.
    ("time_step / 4", "system", "time_step", {"bo1e2": 0.00225, "bo1e3": 0.0007125}),
    ("friction 0.15", "system", "friction", 0.15),
    ("friction 0.6", "system", "friction", 0.6),
    ("rolling_friction 0.05", "system", "rolling_friction", 0.05),
    ("rolling_friction 0.2", "system", "rolling_friction", 0.2),
]


def scan_of(scene, seeds, section, key, value):
    scan = {k: dict(v) for k, v in SCENES[scene].items()}
    scan["scan"]["seeds"] = seeds
    if section is not None:
        scan.setdefault(section, {})[key] = value[scene] if isinstance(value, dict) else value
    return scan


def run(program, scan, path):
    if os.path.exists(path):
        return
    toml = path[:-3] + ".toml"
    with open(toml, "w") as f:
        f.write(to_toml(scan))
    subprocess.run([program, "run", toml, "-o", path, "-q"], check=True)


class Measured:
    """One variant's members: per-member nu_lower_half and mean |Delta y|, the band's profile."""

    def __init__(self, path):
        with h5py.File(path, "r") as f:
            point = f["points/0000"]
            m = point["members"]
            self.failed = int((m["failure"][()] != 0).sum())
            self.nu = m["nu_lower_half"][()]
            self.seed_index = m["seed_index"][()]
            a = point.attrs
            h = float(a["height"])
            self.band = (float(a["cut_bottom"]), h - float(a["cut_top"]))
            self.profile = Profile(point["avalanche_by_ye"], *self.band)
            self.fits = [self.profile.fit(d) for d in range(4)]  # the parabola's verdict: 0-3
            self.mean_abs_dy = float(a["mean_abs_dy_mean"]), float(a["mean_abs_dy_sem"])
            shape = point["abs_dy_histogram/shape_cut"].attrs["preferred"]
            self.histogram = shape.decode() if isinstance(shape, bytes) else str(shape)

    def curvature(self, leave_out=None):
        x, y = self.profile.pooled(leave_out)
        return np.polynomial.polynomial.polyfit(x, y, 2)[2]


def compare(base, var):
    """(d nu_lower_half, its error, d c2, its error) over the paired members; None where the two
    runs lack the same members (a failed member on either side)."""
    if base.failed or var.failed or not np.array_equal(base.seed_index, var.seed_index) or \
            base.profile.members != var.profile.members:
        return None
    dnu = var.nu - base.nu
    n = len(dnu)
    dnu_err = dnu.std(ddof=1) / math.sqrt(n)
    dc = var.curvature() - base.curvature()
    loo = np.array([var.curvature(m) - base.curvature(m) for m in range(n)])
    return float(dnu.mean()), dnu_err, float(dc), float(jackknife(loo))


def row(name, m, d):
    nu_mean, nu_err = m.nu.mean(), m.nu.std(ddof=1) / math.sqrt(len(m.nu))
    holds, _, _ = parabola_verdict(m.band, m.fits, m.profile.members)
    c2, c2_err = m.fits[2][0][2], m.fits[2][1][2]
    out = {"variant": name, "nu_lower_half": nu_mean, "nu_lower_half_err": nu_err, "c2": c2,
           "c2_err": c2_err, "parabola": holds, "mean_abs_dy": m.mean_abs_dy[0],
           "mean_abs_dy_err": m.mean_abs_dy[1], "histogram_cut": m.histogram, "failed": m.failed}
    if d is not None:
        out.update(dnu=d[0], dnu_err=d[1], dc2=d[2], dc2_err=d[3])
    return out


def text(r):
    cells = [r["variant"], f"{r['nu_lower_half']:.4f} +- {r['nu_lower_half_err']:.4f}",
             f"({r['c2'] * 1e4:.1f} +- {r['c2_err'] * 1e4:.1f}) 1e-4",
             "holds" if r["parabola"] else "fails",
             f"{r['mean_abs_dy']:.2f} +- {r['mean_abs_dy_err']:.2f}", r["histogram_cut"]]
    if "dnu" in r:
        cells += [f"{r['dnu']:+.4f} +- {r['dnu_err']:.4f} ({r['dnu'] / r['dnu_err']:+.1f})",
                  f"({r['dc2'] * 1e4:+.1f} +- {r['dc2_err'] * 1e4:.1f}) 1e-4 "
                  f"({r['dc2'] / r['dc2_err']:+.1f})"]
    else:
        cells += ["-", "-"]
    return "| " + " | ".join(cells) + " |"


def environment():
    """Where the record was made: date, commit, CPU, cores."""
    here = os.path.dirname(os.path.abspath(__file__))
    commit = subprocess.run(["git", "-C", here, "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    cpu = ""
    if os.path.exists("/proc/cpuinfo"):
        with open("/proc/cpuinfo") as f:
            cpu = next((l.split(":", 1)[1].strip() for l in f if l.startswith("model name")), "")
    return {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "commit": commit, "cpu": cpu, "cores": os.cpu_count()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", choices=sorted(SCENES), default="bo1e2")
    ap.add_argument("--seeds", type=int, default=16)
    ap.add_argument("--out", default="out/sensitivity")
    ap.add_argument("--program", default=os.environ.get("LOOSEPACK", "build/loosepack"))
    ap.add_argument("--only", default="", help="comma-separated variant names (defaults always)")
    args = ap.parse_args()
    if args.seeds < 4:
        ap.error("--seeds must be 4 or more: the fits' jackknife errors and chi2 need 4 members")
    only = {s.strip() for s in args.only.split(",") if s.strip()}
    os.makedirs(args.out, exist_ok=True)
    print("| variant | nu_lower_half | c2 of Delta y(y_e) | parabola claim | mean abs(Delta y) [R] "
          "| cut histogram | d nu_lower_half (sigma) | d c2 (sigma) |")
    print("|---|---|---|---|---|---|---|---|")
    base = None
    with open(os.path.join(args.out, "sensitivity.jsonl"), "a") as log:
        for name, section, key, value in VARIANTS:
            if only and name != "defaults" and name not in only:
                continue
            stem = name.replace(" ", "_").replace("/", "by")
            path = os.path.join(args.out, f"{args.scene}_{stem}.h5")
            run(args.program, scan_of(args.scene, args.seeds, section, key, value), path)
            m = Measured(path)
            base = base or m
            r = row(name, m, None if m is base else compare(base, m))
            r.update(scene=args.scene, seeds=args.seeds, env=environment())
            print(text(r), flush=True)
            log.write(json.dumps(r) + "\n")


if __name__ == "__main__":
    main()
