"""bench/contact_mobilisation.py on a snapshot made by hand: each contact's mobilisation is its
force over the bound of docs/MODEL.md's contact law (|F_t| <= mu (F_n + F_c), |M| <= mu_r R_c
(F_n + F_c) with R_c = min(R_i, R_j), R_i on the floor; F_n >= -F_c), and the counts near the
bound follow from those ratios."""

import os

import h5py
import numpy as np
import pytest

from script_module import load_script

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "bench", "contact_mobilisation.py")
mob = load_script(SCRIPT)

MU, MU_R, FC = 0.3, 0.1, 10.0


def write_snapshot(path):
    # Disks of radius 1 and 0.5; contacts: disk 0 on the floor, 0-1, 1 on the floor.
    with h5py.File(path, "w") as f:
        point = f.create_group("points/0000")
        point.attrs.update({"friction": MU, "rolling_friction": MU_R, "cohesive_force": FC})
        s = point.create_group("members/snapshot_0")
        s["radius"] = np.array([1.0, 0.5])
        s["contact_i"] = np.array([0, 0, 1])
        s["contact_j"] = np.array([-1, 1, -1])
        s["contact_normal"] = np.array([2.0, -10.0 * 0.995, 0.0])
        # on its sliding bound; none; a tenth of it
        s["contact_tangential"] = np.array([MU * 12.0, 0.0, -0.1 * MU * 10.0])
        # a quarter of the rolling bound with R_c = 1; none; 95 % of it with R_c = 0.5
        s["contact_moment"] = np.array([0.25 * MU_R * 12.0, 0.0, -0.95 * MU_R * 0.5 * 10.0])


def test_mobilisation_is_the_force_over_its_bound(tmp_path):
    path = str(tmp_path / "snap.h5")
    write_snapshot(path)
    (point, name, attrs, group), = list(mob.snapshots(path))
    assert (point, name) == ("0000", "snapshot_0")
    r = mob.mobilisation(group, attrs["friction"], attrs["rolling_friction"],
                         attrs["cohesive_force"])
    assert r["tangential"][0] == pytest.approx(1.0)
    assert r["tangential"][2] == pytest.approx(0.1)
    assert r["rolling"][0] == pytest.approx(0.25)
    assert r["rolling"][2] == pytest.approx(0.95)  # R_c = 0.5, the disk's own radius on the floor
    assert r["tension"][1] == pytest.approx(0.995)
    s = mob.summarise(r)
    assert s["contacts"] == 3
    assert s["tangential"]["within_1_percent"] == 1
    assert s["rolling"]["within_10_percent"] == 1 and s["rolling"]["within_1_percent"] == 0
    assert s["tension"]["within_1_percent"] == 1


def test_a_file_without_snapshots_is_refused(tmp_path):
    path = str(tmp_path / "none.h5")
    with h5py.File(path, "w") as f:
        f.create_group("points/0000/members")
    with pytest.raises(SystemExit, match="no snapshots"):
        mob.main([path])
