"""bench/fluctuation_order.py: the deposition density's fluctuation at y = 200 pooled over result
files by Bond number and box, judged as tools/claims.py judges one file's points."""
import json
import os
import subprocess
import sys

import h5py
import pytest

from script_module import load_script
from test_claims import deposition_file

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "bench", "fluctuation_order.py")
order = load_script(SCRIPT)


def run(*files):
    out = subprocess.run([sys.executable, SCRIPT, *map(str, files), "--json"],
                         capture_output=True, text=True)
    return out.returncode, [json.loads(line) for line in out.stdout.splitlines()], out.stderr


def test_files_of_one_bond_number_each_pool_their_members(tmp_path):
    # Bo = 1e2 in two files of 4 members (other seeds), Bo = 1e3 in a third: 8 and 4 members, and
    # the verdict is claims.py's on the pooled values.
    a = deposition_file(tmp_path, "a", {100.0: 0.15}, width=40.0, members=4, seed=1)
    b = deposition_file(tmp_path, "b", {100.0: 0.15}, width=40.0, members=4, seed=2)
    c = deposition_file(tmp_path, "c", {1000.0: 0.30}, width=40.0, members=4, seed=3)
    rc, (box,), _ = run(a, b, c)
    assert rc == 0
    assert box["pooled"]["100"]["members"] == 8 and box["pooled"]["1000"]["members"] == 4
    values = [v for p in box["points"]["100"] for v in p["members"]]
    assert box["pooled"]["100"]["mean"] == pytest.approx(sum(values) / 8)
    claims = order.claims
    with h5py.File(a) as fa, h5py.File(b) as fb, h5py.File(c) as fc:
        rel = (claims.member_fluctuations(fa["points/0000"])[0] +
               claims.member_fluctuations(fb["points/0000"])[0])
        assert values == pytest.approx(rel)
        at_1e3 = claims.member_fluctuations(fc["points/0000"])[0]
        ok, _ = claims.fluctuation_order({100.0: [("a+b", rel)], 1000.0: [("c", at_1e3)]})
    assert box["holds"] == ok


def test_the_order_is_judged_both_ways(tmp_path):
    # Twice the noise at Bo = 1e3 over 16 members: shown; the reverse: not.
    shown = deposition_file(tmp_path, "shown", {100.0: 0.10, 1000.0: 0.20})
    reverse = deposition_file(tmp_path, "reverse", {100.0: 0.20, 1000.0: 0.10})
    assert run(shown)[1][0]["holds"] is True
    assert run(reverse)[1][0]["holds"] is False


def test_other_boxes_do_not_pool(tmp_path):
    low = deposition_file(tmp_path, "low", {100.0: 0.15}, height=240.0)
    high = deposition_file(tmp_path, "high", {1000.0: 0.20}, height=260.0)
    rc, lines, err = run(low, high)
    assert rc == 2 and not lines and "no box holds" in err
    rc, _, err = run(tmp_path / "missing.h5")
    assert rc == 2 and "missing.h5" in err
