"""tools/pareto.py: the verdict on the default setting, on records made from one of the study's
own lines with their wall times changed."""

import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
TOOL = os.path.join(HERE, "..", "..", "tools", "pareto.py")
RECORD = os.path.join(HERE, "..", "..", "bench", "results", "accuracy-A-cap300-2026-11-24.jsonl")


def verdict(tmp_path, walls):
    """pareto.py's exit code and verdict line on records of these labels and wall times, each
    with the errors of the record's default run."""
    with open(RECORD) as f:
        default = next(r for r in map(json.loads, f)
                       if r["study"] == "accuracy" and r["setup"]["label"] == "default")
    path = tmp_path / "records.jsonl"
    with open(path, "w") as f:
        for label, wall in walls.items():
            r = dict(default, wall_s=wall, setup=dict(default["setup"], label=label))
            f.write(json.dumps(r) + "\n")
    done = subprocess.run([sys.executable, TOOL, str(path)], capture_output=True, text=True)
    return done.returncode, done.stdout.strip().splitlines()[-1]


def test_the_default_is_judged_once_over_its_two_runs(tmp_path):
    """The default's runs took 10 and 10.8 s (timing noise 7.7 %): a setting of equal errors
    at 9.8 s beats the slower run by more than the noise but not the faster one, so the default
    stays on the front; at 9.0 s it beats both, and the default is dominated (exit 1)."""
    code, line = verdict(tmp_path, {"default": 10.0, "default (repeat)": 10.8,
                                    "tolerance=0.003": 9.8})
    assert code == 0 and line == "Protocol A: the default is on the Pareto front (cost: wall)"
    code, line = verdict(tmp_path, {"default": 10.0, "default (repeat)": 10.8,
                                    "tolerance=0.003": 9.0})
    assert code == 1 and line == ("Protocol A: the default is dominated by tolerance=0.003 "
                                  "(cost: wall)")


def test_an_accuracy_record_without_its_fields_is_named(tmp_path):
    """A line of the study's kind that lacks a field the verdict needs: its file, line and the
    field, not a traceback."""
    path = tmp_path / "bad.jsonl"
    path.write_text('\n{"study": "accuracy", "setup": {"label": "x"}}\n')
    done = subprocess.run([sys.executable, TOOL, str(path)], capture_output=True, text=True)
    assert done.returncode == 1 and done.stderr.strip() == (
        f"pareto.py: {path}:2: an accuracy record without 'wall_s'")
