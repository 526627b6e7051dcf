#!/usr/bin/env python3
"""Accuracy against time from `bench_study --study accuracy` records (JSON lines).

    /usr/bin/python3 tools/pareto.py bench/results/accuracy-DATE.jsonl [-o docs/figures/pareto.png]
                            [--cost wall|sweeps]

Prints, per protocol, a Markdown table of every setting (wall time, errors against the
reference, their noise levels, largest overlap) and which settings are on the Pareto front of
wall time against error, and draws the Pareto plot (one row per protocol; error in the nu(y)
profile, in the avalanche profile and the largest overlap against wall time; the front drawn
as a line, the default ringed).

A setting dominates another when it is faster and no worse in every error measure (nu_lower_half,
nu(y) rms, avalanche rms, largest overlap). Differences below the noise level of a measure (the
standard errors of both ensembles combined) are not resolved: within the noise two errors count
as equal. Likewise "faster" means faster by more than the timing noise of the run: the relative
difference of the two runs of the default ("default" and "default (repeat)"), at least 5 %.
Exits with status 1 when the default setting is dominated: each of its runs by one other setting.

--cost sweeps judges cost by the solver sweeps instead of the wall time: a count that does not
depend on the machine's load (no timing noise), comparable only between settings of the same
solver kind (a sweep of another solver costs differently), so settings of other kinds are then
left out of the dominance test. Use it when the two runs of the default disagree by much.
"""
import argparse
import json
import math
import sys

MEASURES = [  # (record field, noise field, axis label)
    ("error_nu_lower_half", "error_nu_lower_half_noise", "|error| in nu_lower_half"),
    ("error_nu_profile_rms", "error_nu_profile_noise", "rms error in nu(y)"),
    ("error_avalanche_rms", "error_avalanche_noise", "rms error in Delta y(y_e) [R]"),
    ("max_overlap", None, "largest overlap [R]"),
]


def load(path):
    runs = {}
    with open(path, errors="replace") as f:  # a binary file fails below, as not JSON
        for n, line in enumerate(f, 1):
            line = line.strip()
            if not line:
                continue
            try:
                r = json.loads(line)
            except json.JSONDecodeError as e:
                sys.exit(f"pareto.py: {path}:{n}: not a JSON record ({e})")
            if not isinstance(r, dict) or r.get("study") != "accuracy":
                continue
            missing = [k for k in ("setup", "wall_s", "sweeps", "over_budget", "failed")
                       if k not in r] or [k for k in ("label", "protocol", "solver")
                                          if k not in r["setup"]]
            if missing:
                sys.exit(f"pareto.py: {path}:{n}: an accuracy record without '{missing[0]}'")
            runs.setdefault(r["setup"]["protocol"], []).append(r)
    if not runs:
        sys.exit(f"pareto.py: {path}: no 'accuracy' records (run bench_study --study accuracy)")
    return runs


def value(r, field):
    v = r.get(field)
    return math.inf if v is None else v


def no_worse(a, b, field, noise):
    """Is a's error no worse than b's, within the noise of the difference?"""
    va, vb = value(a, field), value(b, field)
    tol = 0.0
    if noise:
        tol = math.hypot(value(a, noise) if a.get(noise) is not None else 0.0,
                         value(b, noise) if b.get(noise) is not None else 0.0)
    return va <= vb + tol


def usable(r):
    return not r["over_budget"] and r["failed"] == 0


def timing_noise(rs):
    """Relative run-to-run spread of the default's wall time (at least 5 %)."""
    t = [r["wall_s"] for r in rs if r["setup"]["label"] in ("default", "default (repeat)")]
    if len(t) < 2:
        return 0.05
    return max(0.05, abs(t[0] - t[1]) / (0.5 * (t[0] + t[1])))


def dominates(a, b, noise, cost):
    """Does a dominate b? cost: "wall" (with the timing noise) or "sweeps"."""
    if cost == "sweeps":
        cheaper = (a["setup"]["solver"] == b["setup"]["solver"] and a["sweeps"] < b["sweeps"])
    else:
        cheaper = a["wall_s"] < b["wall_s"] * (1.0 - noise)
    return usable(a) and cheaper and all(no_worse(a, b, f, nz) for f, nz, _ in MEASURES)


def fmt(v, digits=3):
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, (int,)):
        return str(v)
    if v == 0:
        return "0"
    return f"{v:.{digits}g}"


def table(protocol, rs, cost):
    noise = timing_noise(rs)
    print(f"\n### Protocol {protocol}\n")
    print("| setting | wall [s] | core share | sweeps | nu_lower_half | err nu_lh (noise) "
          "| rms err nu(y) (noise) | rms err Delta y [R] (noise) | max overlap [R] | front | dominated by |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rs:
        by = [o["setup"]["label"] for o in rs if o is not r and dominates(o, r, noise, cost)]
        front = usable(r) and not by
        # Sweeps of different solvers cost different time: with that cost a setting whose solver
        # no other setting uses is compared with nothing, so it is not called front.
        alone = cost == "sweeps" and not any(
            o is not r and o["setup"]["solver"] == r["setup"]["solver"] for o in rs)
        front_cell = "n/a (solver compared with none)" if alone else ("yes" if front else "")
        note = " (over budget)" if r["over_budget"] else (f" ({r['failed']} failed)" if r["failed"] else "")
        print(f"| {r['setup']['label']}{note} | {fmt(r['wall_s'])} | {fmt(r['core_share'], 2)} | {r['sweeps']} "
              f"| {fmt(r['nu_lower_half'])} +- {fmt(r['nu_lower_half_sem'], 2)} "
              f"| {fmt(r['error_nu_lower_half'], 2)} ({fmt(r['error_nu_lower_half_noise'], 2)}) "
              f"| {fmt(r['error_nu_profile_rms'], 2)} ({fmt(r['error_nu_profile_noise'], 2)}) "
              f"| {fmt(r['error_avalanche_rms'], 2)} ({fmt(r['error_avalanche_noise'], 2)}) "
              f"| {fmt(r['max_overlap'], 2)} | {front_cell} | {', '.join(by)} |")
    ref = rs[0].get("reference_wall_s")
    print(f"\nReference (tolerance 1e-5, sweep cap 20000, half the time step): {fmt(ref)} s; "
          f"timing noise (two runs of the default): {100 * noise:.0f} %.")


def plot(runs, out):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    protocols = sorted(runs)
    fig, axes = plt.subplots(len(protocols), 3, figsize=(15, 4.5 * len(protocols)), squeeze=False)
    for row, p in zip(axes, protocols):
        rs = [r for r in runs[p] if usable(r)]
        for ax, (field, noise, name) in zip(row, MEASURES[1:]):
            for r in rs:
                x, y = r["wall_s"], value(r, field)
                if not math.isfinite(y):
                    continue
                is_default = r["setup"]["label"] == "default"
                ax.plot([x], [max(y, 1e-12)], "o", ms=9 if is_default else 5,
                        mfc="none" if is_default else None, color="C3" if is_default else "C0")
                ax.annotate(r["setup"]["label"], (x, max(y, 1e-12)), fontsize=7,
                            xytext=(3, 3), textcoords="offset points")
            # The front of this measure alone: the lowest error reached at each time.
            pts = sorted((r["wall_s"], value(r, field)) for r in rs if math.isfinite(value(r, field)))
            front, best = [], math.inf
            for x, y in pts:
                if y < best:
                    front.append((x, max(y, 1e-12)))
                    best = y
            if front:
                ax.step([x for x, _ in front], [y for _, y in front], where="post", color="C2",
                        lw=1, label="front of this measure")
            if noise:
                nz = [r[noise] for r in rs if r.get(noise)]
                if nz:
                    ax.axhline(sum(nz) / len(nz), ls=":", color="grey",
                               label="noise level (differences below are not resolved)")
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel("wall time of the ensemble [s]")
            ax.set_ylabel(name)
            ax.set_title(f"protocol {p}")
            ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"\nwrote {out}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("records")
    ap.add_argument("-o", "--output", help="Pareto plot (PNG); none when absent")
    ap.add_argument("--cost", choices=("wall", "sweeps"), default="wall",
                    help="what 'faster' compares (default: wall time with its noise)")
    a = ap.parse_args()
    try:
        runs = load(a.records)
    except OSError as e:
        sys.exit(f"pareto.py: {e}")
    dominated = False
    for p in sorted(runs):
        table(p, runs[p], a.cost)
        # The default setting is dominated where each of its runs is, by another setting (its
        # runs differ by the timing noise, which the test allows for).
        d = [r for r in runs[p] if r["setup"]["label"].startswith("default")]
        by = set.intersection(*({o["setup"]["label"] for o in runs[p]
                                 if o not in d and dominates(o, r, timing_noise(runs[p]), a.cost)}
                                for r in d)) if d else set()
        if d and by:
            dominated = True
            print(f"\nProtocol {p}: the default is dominated by {', '.join(sorted(set(by)))} "
                  f"(cost: {a.cost})")
        elif d:
            print(f"\nProtocol {p}: the default is on the Pareto front (cost: {a.cost})")
    if a.output:
        plot(runs, a.output)
    sys.exit(1 if dominated else 0)


if __name__ == "__main__":
    main()
