#!/usr/bin/env python3
"""The tables of docs/PERFORMANCE.md ("Building for more cores or a GPU") from the lines of
bench/gpu_study.sh (OUT/runs.jsonl, or a bench/results/gpu-study-*.jsonl record).

    bench/gpu_summary.py RUNS.jsonl

Prints, per scene: the host core's and each whole device run's seconds per member, the host
cores the GPU is worth (host seconds per member over the device's), the main observable of
each with the difference in combined standard errors, and for runs with --timing the solve's
balance; then the milliseconds per step of each stage for every device run with stages, and
where each run's wall time went (before its members, the loop, around it, after).
"""
import json
import math
import sys


def load(path):
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def observable(run):
    """The summary's main observable, nu_lower_half: (value, error), or None for a stopped run."""
    return tuple(run["nu_lower_half"]) if "nu_lower_half" in run else None


def sigma(a, b):
    (va, ea), (vb, eb) = a, b
    combined = math.hypot(ea, eb)
    return abs(va - vb) / combined if combined > 0 else float("nan")


def whole_device_runs(runs):
    return [r for r in runs if r.get("where") == "device" and "-prefix" not in r.get("variant", "")]


def ratio_table(runs):
    host = {r["scene"]: r for r in runs if r.get("where") == "host"}
    lines = [
        "| scene | device run | members | batch | sweeps a launch | device s per member"
        " | host core s per member | host cores the GPU is worth | observable, device"
        " | observable, host | difference |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in whole_device_runs(runs):
        h = host.get(r["scene"])
        worth = h["per_member_s"] / r["per_member_s"] if h and r["per_member_s"] > 0 else None
        obs_d, obs_h = observable(r), observable(h) if h else None
        lines.append(
            "| {} | {} | {} | {} | {} | {:.4f} | {} | {} | {} | {} | {} |".format(
                r["scene"],
                r.get("variant", ""),
                r["members"],
                r.get("batch", r["members"]),
                r.get("sweeps_per_launch", 0),
                r["per_member_s"],
                "{:.4f}".format(h["per_member_s"]) if h else "-",
                "{:.1f}".format(worth) if worth else "-",
                "{:.4f} +- {:.4f}".format(*obs_d) if obs_d else "-",
                "{:.4f} +- {:.4f}".format(*obs_h) if obs_h else "-",
                "{:.1f} sigma".format(sigma(obs_d, obs_h)) if obs_d and obs_h else "-",
            )
        )
    return lines if len(lines) > 2 else []


def balance_table(runs):
    lines = [
        "| scene | run | launches | systems a launch | their sweeps, % of the slowest's"
        " | slowest system's sweeps a launch | system steps ended a launch |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in runs:
        if "balance" not in r:
            continue
        n, share, slowest, ended = r["balance"]
        lines.append(
            "| {} | {} | {} | {} | {} | {} | {} |".format(
                r["scene"],
                " ".join(x for x in (r.get("where"), r.get("variant")) if x)
                + " {} members, batch {}, K = {}".format(
                    r["members"], r.get("batch", r["members"]), r.get("sweeps_per_launch", 0)
                ),
                r.get("steps"),
                n,
                share,
                slowest,
                ended,
            )
        )
    return lines if len(lines) > 2 else []


def stage_table(runs):
    with_stages = [r for r in runs if r.get("where") == "device" and r.get("stages") and r.get("steps")]
    if not with_stages:
        return []
    # "scheduler" (what the run's loop does between the steps) and "snapshots" (the running
    # members' snapshots taken in it) are no stages of the step: they follow "the step".
    between = ["scheduler", "snapshots"]
    names = []
    for r in with_stages:
        for name in r["stages"]:
            if name not in names and name not in between:
                names.append(name)
    tail = ["the step"] + [b for b in between if any(b in r["stages"] for r in with_stages)]
    head = ["{} {}".format(r["scene"], r.get("variant", "")) for r in with_stages]
    lines = ["| stage, ms per step | " + " | ".join(head) + " |", "|---|" + "---|" * len(head)]
    for name in names + tail:
        cells = []
        for r in with_stages:
            if name == "the step":
                seconds = sum(v[0] if isinstance(v, list) else v
                              for k, v in r["stages"].items() if k not in between)
            elif name in r["stages"]:
                v = r["stages"][name]
                seconds = v[0] if isinstance(v, list) else v
            else:
                cells.append("-")
                continue
            cells.append("{:.3f}".format(1000.0 * seconds / r["steps"]))
        lines.append("| {} | ".format(name) + " | ".join(cells) + " |")
    return lines


def wall_table(runs):
    """Where each run's wall time went (the runs with --timing that finished)."""
    with_parts = [r for r in runs if r.get("wall_parts")]
    if not with_parts:
        return []
    lines = [
        "| scene | run | wall s (the script's) | program s | before the members | the loop"
        " | set-up and last checkpoint | after (analysis, file) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in with_parts:
        w = r["wall_parts"]
        lines.append(
            "| {} | {} | {:.2f} | {:.2f} | {:.2f} | {:.2f} | {:.2f} | {:.2f} |".format(
                r["scene"],
                " ".join(x for x in (r.get("where"), r.get("variant")) if x),
                r["wall_s"], w["program_s"], w["before_s"], w["loop_s"], w["around_loop_s"],
                w["after_s"],
            )
        )
    return lines


def main(argv):
    if len(argv) != 2:
        sys.stderr.write("usage: bench/gpu_summary.py RUNS.jsonl\n")
        return 2
    runs = load(argv[1])
    for table in (ratio_table(runs), balance_table(runs), stage_table(runs), wall_table(runs)):
        if table:
            print("\n".join(table))
            print()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
