"""The Python package (python/loosepack) on a small scan run through it: every object it reads
checked against what the file's own data or a formula says it must be."""

import math
import os
import shutil
import subprocess
import tomllib

import h5py
import numpy as np
import pytest

import loosepack

SCAN = {
    "scan": {"name": "python", "seed": 7, "seeds": 3, "protocol": "A"},
    "system": {"width": 12.0, "height": 12.0, "bond_number": [0, 100]},
    "observables": {"trajectory_every": 2},
}


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "python.h5"
    return loosepack.run(SCAN, out, progress=False, args=["--snapshots"])


def test_points_table_has_parameters_scalars_and_integer_counts(result):
    p = result.points
    assert list(p.index) == [0, 1]
    assert list(p["bond_number"]) == [0.0, 100.0]
    assert p["members"].dtype.kind == "i" and list(p["members"]) == [3, 3]
    assert list(p["failed"]) == [0, 0]
    # The default time step resolves the cohesive barrier: 0.9 sqrt(d_c / (Bo g)), at most 0.01.
    assert p.loc[0, "time_step"] == 0.01
    assert p.loc[1, "time_step"] == pytest.approx(0.9 * math.sqrt(0.01 / 100.0))
    # The observable lengths of a 12 R box: min(50, H/4) and min(20, H/6).
    assert p.loc[0, "lower_half_from"] == 3.0 and p.loc[0, "cut_top"] == 2.0
    assert (p["nu_lower_half_n"] == 3).all()
    assert ((p["nu_lower_half"] > 0) & (p["nu_lower_half"] < math.pi / (2 * math.sqrt(3)))).all()
    assert result.scan_text.startswith("[scan]")
    assert isinstance(result.attrs["program"], str) and result.attrs["seeds"] == 3


def test_every_dataset_says_what_it_holds(result):
    """docs/OUTPUT.md: every dataset has a long_name, and a volume fraction the units 1."""
    missing = []
    with h5py.File(result.path, "r") as f:
        f.visititems(lambda name, obj: missing.append(name) if isinstance(obj, h5py.Dataset)
                     and "long_name" not in obj.attrs else None)
        for name in ("mean", "predicted", "deviation"):
            assert f[f"points/0001/nu/{name}"].attrs["units"] == "1", name
        # counts are 64-bit integers, a fit's degrees of freedom and points too
        fit = f["points/0001/avalanche_by_ye/fit"].attrs
        assert fit["dof"].dtype == "int64" and fit["points"].dtype == "int64"
        assert fit["points"] - fit["dof"] == 3  # a parabola's three coefficients
    assert not missing, missing


def test_nu_profile_is_the_mean_of_its_member_rows(result):
    nu = result.nu(1)
    assert nu["y"].attrs["units"] == "R" and nu["mean"].attrs["units"] == "1"
    rows = nu["member_mean"]
    assert rows.dims == ("member", "y") and list(nu["member"]) == [0, 1, 2]
    full = nu["members"] == 3
    assert np.allclose(rows.mean("member")[full], nu["mean"][full])
    sem = rows.std("member", ddof=1) / math.sqrt(3)
    assert np.allclose(sem[full], nu["sem"][full])


def test_histogram_counts_every_disk_and_members_agree(result):
    for point in (0, 1):
        members = result.members(point)
        # The point's mean abs(Delta y) is the mean of its members' (each over its own disks).
        assert members["mean_abs_dy"].mean() == pytest.approx(
            result.points.loc[point, "mean_abs_dy"], rel=1e-12)
        assert members["disks"].dtype.kind == "i"
        assert list(members["seed_index"]) == [0, 1, 2]
        assert int(result.histogram(point).sum()) == int(members["disks"].sum())
        assert int(result.histogram(point, cut=True).sum()) <= int(members["disks"].sum())
        # One row per member, each counting that member's disks; the rows add up to the counts.
        rows = result.histogram(point, members=True)
        assert list(rows["member"]) == [0, 1, 2]
        assert list(rows.sum("abs_dy").values) == list(members["disks"].values)
        for cut in (False, True):
            assert np.array_equal(result.histogram(point, cut, members=True).sum("member"),
                                  result.histogram(point, cut))
    av = result.avalanche(1, by="y_e")
    assert av["count"].sum() == result.members(1)["disks"].sum()
    with pytest.raises(ValueError):
        result.avalanche(1, by="z")


def test_snapshots_contacts_and_trajectories(result):
    members = result.members(1)
    disks = result.snapshot(1, seed=2)
    assert len(disks) == members["disks"][2]
    assert np.allclose(disks["dy"], disks["y_e"] - disks["y_i"])
    assert ((disks["x"] >= 0) & (disks["x"] < 12.0)).all()
    contacts = result.contacts(1, seed=2)
    assert contacts["i"].dtype.kind == "i"
    assert ((contacts["j"] >= -1) & (contacts["j"] < len(disks))).all()
    # Without cohesion the floor carries the whole deposit at rest: the floor contacts' normal
    # forces sum to its weight (each disk m = 1 of radius R = 1, g = 1), within the solve's scale
    # of error: the tolerance [h m g] on every contact (the sweeps end when no impulse changes by
    # more in a sweep; a scale, not a strict bound, which the creep below the rest speed would
    # loosen to 2 v_rest / h per disk).
    bare = result.snapshot(0, seed=2)
    every = result.contacts(0, seed=2)
    floor = every.query("j == -1")
    tolerance = result.points.loc[0, "solver_tolerance"] * len(every)
    assert abs(floor["normal"].sum() - len(bare)) <= tolerance
    trajectory = result.trajectory(1, seed=0)
    assert (trajectory["disk"] % 2 == 0).all()
    with pytest.raises(KeyError, match="snapshot_9"):
        result.snapshot(1, seed=9)


def test_fits_are_read_with_their_errors(result):
    fits = result.fits(1)
    assert {"avalanche_by_yi/fit", "avalanche_by_ye/fit", "nu_deposition/power_law"} <= set(fits)
    for name, fit in fits.items():  # a valid fit has its parameters, an invalid one none
        if "coef" not in fit:  # a verdict or other analysis result, not a fit
            continue
        assert len(fit["coef"]) == len(fit["error"]), name
        assert (len(fit["coef"]) > 0) == bool(fit["valid"]), name
        assert "reduced_chi2" in fit


def test_verdicts_events_and_fits_across_points(result):
    """fits() holds the histograms' verdicts beside their fits; events() counts one event per
    deposited disk (those without motion apart), in every member's row as in the pooled one."""
    fits = result.fits(0)
    assert fits["abs_dy_histogram/shape_cut"]["preferred"] in (
        "gaussian", "exponential", "neither", "none")
    assert "rms_deviation" in fits["nu"]
    assert {"mean", "mean_error", "slope", "slope_error"} <= set(fits["nu/deviation_terms"])
    events = result.events(1)
    disks = int(result.members(1)["disks"].sum())
    assert int(events["steps_counts"].sum()) == disks  # every event by its steps to rest
    assert (events["member_moved_counts"].sum("member") == events["moved_counts"]).all()
    assert int(events["moved_counts"].sum()) + events.attrs["without_motion"] == disks
    assert (events["lower_edge"] < events["bin"]).all() and (events["bin"] < events["upper_edge"]).all()
    assert result.across() == {}  # two Bond numbers: no fit across points


def test_points_are_named_by_index_and_wrong_files_are_named(result, tmp_path):
    assert np.array_equal(result.nu("1")["mean"], result.nu(1)["mean"])
    assert np.array_equal(result.nu(np.int64(1))["mean"], result.nu("0001")["mean"])
    for bad in (1.5, -1, "x", True):
        with pytest.raises(KeyError, match="a point is named by its index"):
            result.nu(bad)
    # A seed without a snapshot, in a file that has snapshots: no advice to run --snapshots.
    with pytest.raises(KeyError) as e:
        result.snapshot(1, seed=9)
    assert "--snapshots" not in str(e.value)
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = [1.0]
    with pytest.raises(ValueError, match="not a loosepack result file"):
        loosepack.load(other)
    # A result file lacking a group or an attribute names the file and the object.
    damaged = tmp_path / "damaged.h5"
    damaged.write_bytes(open(result.path, "rb").read())
    with h5py.File(damaged, "r+") as f:
        del f["points/0001/nu"]
        del f["points/0001/members/seed_index"]
    with pytest.raises(KeyError, match="damaged.h5: /points/0001/nu is missing"):
        loosepack.load(damaged).nu(1)
    with pytest.raises(KeyError, match="damaged.h5: /points/0001/members/seed_index is missing"):
        loosepack.load(damaged).avalanche(1)
    with h5py.File(damaged, "r+") as f:
        del f["points/0000"].attrs["protocol"]
    with pytest.raises(ValueError, match="/points/0000 has no attribute 'protocol'"):
        loosepack.load(damaged)
    # A file damaged after it was loaded (here cut short): HDF5's own error, named with the file.
    cut = tmp_path / "cut.h5"
    cut.write_bytes(open(result.path, "rb").read())
    loaded = loosepack.load(cut)
    cut.write_bytes(open(result.path, "rb").read()[:4096])
    for read in (lambda: loaded.fits(1), lambda: loaded.snapshot(1), lambda: loaded.nu(1)):
        with pytest.raises(ValueError, match="cut.h5: the file is damaged or was edited"):
            read()
    (tmp_path / "text.h5").write_text("not hdf5")
    with pytest.raises(ValueError, match="not an HDF5 file"):
        loosepack.load(tmp_path / "text.h5")
    with pytest.raises(loosepack.LoosepackError, match="does not exist"):
        loosepack.run(SCAN, tmp_path / "nodir" / "x.h5", progress=False)


def test_file_stores_integers_units_and_strings(result):
    with h5py.File(result.path, "r") as f:
        g = f["points/0001"]
        assert g["members/seed_index"].dtype.kind == "i"
        assert g["abs_dy_histogram/counts"].dtype.kind == "i"
        assert g.attrs["members"].dtype.kind == "i"
        assert g["nu/mean"].attrs["units"] == "1"
        assert isinstance(g.attrs["protocol"], str)
        assert isinstance(f["scan_text"].asstr()[()], str)


def test_older_layout_still_loads(result, tmp_path):
    old = tmp_path / "old.h5"
    shutil.copy(result.path, old)
    with h5py.File(old, "r+") as f:  # counts as float64, strings of fixed length, no rows
        for name in ("0000", "0001"):
            g = f["points"][name]
            g.attrs.modify("members", np.float64(3.0))
            g.attrs.create("protocol", np.bytes_(b"A"))
            del g["nu/member_mean"]
    res = loosepack.load(old)
    assert list(res.points["members"]) == [3, 3] and res.points["members"].dtype.kind == "i"
    assert list(res.points["protocol"]) == ["A", "A"]
    assert "member_mean" not in res.nu(0)


def test_scan_dicts_become_scan_files():
    scan = {"scan": {"name": "x", "seeds": 2},
            "system": {"bond_number": {"from": 1, "to": 1e4, "points": 5, "log": True},
                       "friction": [0.3, 0.5], "capture_radius": float("inf")},
            "point": [{"height": 24.0}, {"height": 48.0}]}
    back = tomllib.loads(loosepack.to_toml(scan))
    assert back["system"]["bond_number"] == scan["system"]["bond_number"]
    assert back["system"]["capture_radius"] == "inf"
    assert back["point"] == scan["point"]
    # numpy's values (a linspace of heights, a count) are written as the numbers they hold.
    heights = np.linspace(8.0, 12.0, 3)
    back = tomllib.loads(loosepack.to_toml({"scan": {"seeds": np.int64(2)},
                                            "system": {"height": heights, "width": heights[0]}}))
    assert back["scan"]["seeds"] == 2 and back["system"]["width"] == 8.0
    assert back["system"]["height"] == [8.0, 10.0, 12.0]


def test_bad_input_raises_with_the_programs_message(tmp_path):
    """The message points into the scan file the dict would be written to (bad.toml beside
    bad.h5, as its text would be there), which a refused scan does not leave behind, so that the
    corrected dict runs; a bad.toml of another scan is not replaced unasked, nor by a scan the
    program refuses."""
    bad = {"system": {"width": 12.0, "height": 12.0, "widht": 3.0}}
    with pytest.raises(loosepack.LoosepackError) as e:
        loosepack.run(bad, tmp_path / "bad.h5", progress=False)
    assert e.value.returncode == 2 and f"{tmp_path / 'bad.toml'}:4:9: key 'system.widht'" in str(
        e.value), str(e.value)
    assert "bad.toml not written" in str(e.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    good = {"system": {"width": 12.0, "height": 12.0, "bond_number": "inf"}}
    loosepack.run(good, tmp_path / "bad.h5", progress=False)
    other = {"system": {"width": 14.0, "height": 12.0, "bond_number": "inf"}}
    with pytest.raises(loosepack.LoosepackError) as e:
        loosepack.run(other, tmp_path / "bad.h5", progress=False)
    assert "bad.toml exists with another scan" in str(e.value)
    res = loosepack.run(good, tmp_path / "bad.h5", progress=False, force=True)
    assert res.attrs["scan_file"] == str(tmp_path / "bad.toml")
    # With force, a scan the program refuses does not replace the scan beside the result: the
    # message points into the new text as it would be there.
    with pytest.raises(loosepack.LoosepackError) as e:
        loosepack.run(bad, tmp_path / "bad.h5", progress=False, force=True)
    assert f"{tmp_path / 'bad.toml'}:4:9: key 'system.widht'" in str(e.value), str(e.value)
    assert "kept its earlier scan" in str(e.value)
    assert (tmp_path / "bad.toml").read_text() == loosepack.to_toml(good)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.h5", "bad.toml"]
    with pytest.raises(loosepack.LoosepackError):
        loosepack.run(good, tmp_path / "x.toml", progress=False)


def umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


LONG = {"scan": {"name": "long", "seeds": 2, "protocol": "A"},
        "system": {"width": 30.0, "height": 60.0, "bond_number": 1000.0}}


def test_an_interrupted_python_run_stops_the_program_with_its_checkpoint(tmp_path, monkeypatch,
                                                                          capsys):
    """A KeyboardInterrupt that reaches Python alone, at the first progress line: run() stops
    the program, which saves its checkpoint and writes no file, before the exception goes on.
    Then a dict of another scan is refused (a checkpoint of the first to resume) and the scan
    file the resume needs still holds the first scan, which resumes."""
    out = tmp_path / "long.h5"

    def interrupt(line, progress):
        if "members," in line:
            raise KeyboardInterrupt

    monkeypatch.setattr(loosepack.runner, "_show", interrupt)
    with pytest.raises(KeyboardInterrupt):
        loosepack.run(LONG, out)
    monkeypatch.undo()
    assert "continue with: loosepack run" in capsys.readouterr().err  # the program's last words
    assert oct((tmp_path / "long.toml").stat().st_mode & 0o777) == oct(0o666 & ~umask())
    assert not out.exists() and (tmp_path / "long.h5.checkpoint").is_dir()
    assert not (tmp_path / "long.h5.lock").exists()  # the program has ended
    other = {"scan": dict(LONG["scan"], seeds=3), "system": LONG["system"]}
    with pytest.raises(loosepack.LoosepackError) as e:
        loosepack.run(other, out, progress=False, force=True)
    assert e.value.returncode == 2 and "long.toml kept its earlier scan" in str(e.value), str(
        e.value)
    assert (tmp_path / "long.toml").read_text() == loosepack.to_toml(LONG)
    resume = subprocess.run([loosepack.find_program(), "run", str(tmp_path / "long.toml"), "-o",
                             str(out), "--resume", "--dry-run"], capture_output=True, text=True)
    assert resume.returncode == 0, resume.stderr


def test_a_failed_members_state_is_read_and_named(tmp_path, monkeypatch):
    """A member made to fail (LOOSEPACK_INJECT_NAN=<id>: src/fault_injection.hpp) leaves its state
    at the failure, which failure() reads with the reason; snapshot() names it where the run
    wrote no snapshots."""
    monkeypatch.setenv("LOOSEPACK_INJECT_NAN", "1")
    scan = {"scan": {"seeds": 2}, "system": {"width": 12.0, "height": 12.0, "bond_number": 30}}
    res = loosepack.run(scan, tmp_path / "fail.h5", progress=False)
    state = res.failure(0, 1)
    assert len(state) > 0 and not np.isfinite(state["vy"]).all()
    assert state.attrs == {"member": 1, "failure": "non-finite position or velocity (NaN or Inf)"}
    with pytest.raises(KeyError, match=r"no snapshot_1 .*run with --snapshots; failed members' "
                                       r"states at the failure: failure_1 \(failure\(point, seed\)\)"):
        res.snapshot(0, 1)
    with pytest.raises(KeyError, match="no failure_0"):
        res.failure(0, 0)


def test_a_failed_members_snapshot_is_no_deposit(tmp_path, monkeypatch):
    """With --snapshots a failed member (LOOSEPACK_INJECT_NAN=1: member 1, seed 1) has no
    snapshot_1, only its state at the failure: snapshot() names failure(); a finished member's
    snapshot is there."""
    monkeypatch.setenv("LOOSEPACK_INJECT_NAN", "1")
    scan = {"scan": {"seeds": 2}, "system": {"width": 12.0, "height": 12.0, "bond_number": 30}}
    res = loosepack.run(scan, tmp_path / "fail.h5", progress=False, args=["--snapshots"])
    with pytest.raises(KeyError, match=r"no snapshot_1 \(has: snapshot_0\); failed members' "
                                       r"states at the failure: failure_1"):
        res.snapshot(0, 1)
    assert len(res.snapshot(0, 0)) > 0 and len(res.contacts(0, 0)) > 0


def test_summary_prints_the_table(result):
    text = loosepack.summary(result.path)
    assert "nu_lower_half" in text and "0001" in text
