"""bench/sensitivity.py: a variant's row and its paired difference from the defaults, on result
files written with h5py whose profiles are known (a parabola, and the same parabola steeper)."""
import math
import os

import h5py
import numpy as np

import test_claims
from script_module import load_script

HERE = os.path.dirname(os.path.abspath(__file__))
sensitivity = load_script(os.path.join(HERE, "..", "..", "bench", "sensitivity.py"))


def variant(tmp_path, name, scale):
    """A point of 16 members whose Delta y(y_e) is `scale` times the claims tests' parabola."""
    path = test_claims.point_file(tmp_path, name, "A", 1000.0,
                                  {"avalanche_by_ye": lambda y: scale * test_claims.PARABOLA(y)})
    members = test_claims.MEMBERS
    with h5py.File(path, "r+") as f:
        g = f["points/0000"]
        g.attrs.update({"mean_abs_dy_mean": 2.0 * scale, "mean_abs_dy_sem": 0.1})
        g["members/failure"] = np.zeros(members, dtype=np.int32)
        g["members/nu_lower_half"] = np.linspace(0.40, 0.42, members) + \
            1e-3 * scale * np.sin(np.arange(members))
        g["members/seed_index"] = np.arange(members)
        g.create_group("abs_dy_histogram/shape_cut").attrs["preferred"] = "gaussian"
    return sensitivity.Measured(str(path))


def test_a_steeper_parabola_shows_as_a_curvature_difference(tmp_path):
    base, steep = variant(tmp_path, "base", 1.0), variant(tmp_path, "steep", 2.0)
    row = sensitivity.row("steeper", steep, sensitivity.compare(base, steep))
    assert row["parabola"]  # the claims' verdict on a parabola with positive curvature
    c2 = 0.004  # the parabola's: -0.004 y (H - y)
    assert math.isclose(row["c2"], 2 * c2, rel_tol=0.05)
    assert math.isclose(row["dc2"], c2, rel_tol=0.1)
    shift = 1e-3 * np.sin(np.arange(test_claims.MEMBERS))  # the members' paired differences
    assert math.isclose(row["dnu"], shift.mean(), rel_tol=1e-9)
    assert math.isclose(row["dnu_err"], shift.std(ddof=1) / math.sqrt(shift.size), rel_tol=1e-9)
    assert sensitivity.text(row).startswith("| steeper |")
