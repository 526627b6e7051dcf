"""bench/gpu_summary.py, the device study's tables, on the recorded H200 study
(bench/results/gpu-study-h200-2026-11-26.jsonl): each table row follows from the record's own
fields (host cores the GPU is worth = host seconds per member / device seconds per member;
milliseconds per stage = fenced seconds / steps), and the host-only runs of the balance study
give no ratio row."""

import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
SCRIPT = os.path.join(ROOT, "bench", "gpu_summary.py")
STUDY = os.path.join(ROOT, "bench", "results", "gpu-study-h200-2026-11-26.jsonl")
BALANCE = os.path.join(ROOT, "bench", "results", "sweeps-per-launch-serial-2026-11-26.jsonl")


def summary(path):
    out = subprocess.run([sys.executable, SCRIPT, path], capture_output=True, text=True, check=True)
    return out.stdout


def rows(text, first_cell):
    return [
        [c.strip() for c in line.strip("|").split("|")]
        for line in text.splitlines()
        if line.startswith("| " + first_cell)
    ]


def test_host_cores_the_gpu_is_worth_follow_from_the_record():
    with open(STUDY) as f:
        runs = [json.loads(line) for line in f if line.strip()]
    host = {r["scene"]: r["per_member_s"] for r in runs if r["where"] == "host"}
    device = {
        r["scene"]: r["per_member_s"]
        for r in runs
        if r["where"] == "device" and r["variant"] == "after"
    }
    text = summary(STUDY)
    for scene in ("C", "A"):
        (row,) = [r for r in rows(text, scene) if r[1] == "after" and len(r) == 11]
        assert float(row[7]) == round(host[scene] / device[scene], 1)
    step = [r for r in rows(text, "the step")][0]
    # A column for every device run with stages (prefixes included), after the row's name.
    with_stages = sum(1 for r in runs if r["where"] == "device" and "stages" in r)
    assert len(step) == 1 + with_stages


def test_runs_on_one_core_give_the_balance_but_no_ratio():
    with open(BALANCE) as f:
        runs = [json.loads(line) for line in f if line.strip()]
    text = summary(BALANCE)
    assert "host cores the GPU is worth" not in text
    balance = rows(text, "C") + rows(text, "A")
    assert len(balance) == len(runs)  # one row per run: all were timed
    for row in balance:
        assert float(row[4]) <= 100.0  # a share of the slowest system's sweeps
    launches = sorted(int(r[2]) for r in balance)
    assert launches == sorted(r["steps"] for r in runs)


def test_the_scheduler_follows_the_step_and_is_not_part_of_it(tmp_path):
    """`--timing`'s "scheduler" (the run's loop between the steps) and "snapshots" (the snapshots
    taken in it) get their own rows after "the step", whose milliseconds are the stages' alone."""
    run = {"where": "device", "variant": "after", "scene": "A", "members": 4, "batch": 4,
           "per_member_s": 1.0, "steps": 1000,
           "stages": {"grid": [0.5, 6, 2], "solve": [2.0, 1, 0], "scheduler": [4.0, 1, 2],
                      "snapshots": [8.0, 0, 30]}}
    path = tmp_path / "runs.jsonl"
    path.write_text(json.dumps(run) + "\n")
    text = summary(str(path))
    names = [r[0] for r in rows(text, "")][-5:]
    assert names == ["grid", "solve", "the step", "scheduler", "snapshots"]
    (step,) = rows(text, "the step")
    (scheduler,) = rows(text, "scheduler")
    (snapshots,) = rows(text, "snapshots")
    assert float(step[1]) == 1000.0 * (0.5 + 2.0) / 1000
    assert float(scheduler[1]) == 1000.0 * 4.0 / 1000
    assert float(snapshots[1]) == 1000.0 * 8.0 / 1000
