"""bench/combine_paired.py: independent paired comparisons pooled by inverse-variance weights,
the pooled error 1/sqrt(sum of 1/error^2), and only the quantities every record pairs."""

import json
import os
import subprocess
import sys

import pytest

from script_module import load_script

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "bench", "combine_paired.py")
combine = load_script(SCRIPT)


def test_equal_errors_average_and_shrink_by_root_two():
    d, e = combine.pooled([(1.0, 0.5), (3.0, 0.5)])
    assert d == pytest.approx(2.0) and e == pytest.approx(0.5 / 2**0.5)


def test_weights_are_inverse_variances():
    # Errors 1 and 2: weights 1 and 1/4, so (0 * 1 + 5 / 4) / (5 / 4) = 1, error 1/sqrt(5/4).
    d, e = combine.pooled([(0.0, 1.0), (5.0, 2.0)])
    assert d == pytest.approx(1.0) and e == pytest.approx(1 / 1.25**0.5)


def test_the_table_pools_what_every_record_pairs(tmp_path):
    def record(difference, error):
        rows = [{"quantity": "nu_lower_half", "paired_difference": difference,
                 "paired_error": error},
                {"quantity": "nu(y)", "distance": 3.0}]  # a chi2 row: not pooled
        return json.dumps({"label": "x", "rows": rows})
    first, second = tmp_path / "a.jsonl", tmp_path / "b.jsonl"
    first.write_text(record(0.3, 0.1) + "\n")
    second.write_text(record(0.1, 0.1) + "\n")
    out = subprocess.run([sys.executable, SCRIPT, str(first), str(second)], capture_output=True,
                         text=True)
    assert out.returncode == 0, out.stderr
    # (0.3 + 0.1) / 2 = 0.2 +- 0.1 / sqrt(2) = 0.0707: 2.83 sigma, beyond the default 2.
    line = next(l for l in out.stdout.splitlines() if l.startswith("| nu_lower_half"))
    assert "0.2 +- 0.071 | 2.83 sigma | NO" in line, line
    assert "nu(y)" not in out.stdout
    alone = subprocess.run([sys.executable, SCRIPT, str(first)], capture_output=True, text=True)
    assert alone.returncode == 2 and "two or more records" in alone.stderr
    unpaired = tmp_path / "unpaired.jsonl"  # a record of compare.py without --paired
    unpaired.write_text(json.dumps({"rows": [{"quantity": "nu_lower_half", "distance": 1.0}]}))
    out = subprocess.run([sys.executable, SCRIPT, str(first), str(unpaired)], capture_output=True,
                         text=True)
    assert out.returncode == 2 and "unpaired.jsonl:1: no paired quantity" in out.stderr
