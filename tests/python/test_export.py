"""`loosepack export`: the XDMF files opened by ParaView's own reader and the extended XYZ read
back by ASE, each compared with the disks, contacts and trajectories of the result file."""

import os
import re
import subprocess
import sys

import h5py
import numpy as np
import pytest

import loosepack

SCAN = {
    "scan": {"name": "export", "seed": 11, "seeds": 2, "protocol": "A"},
    "system": {"width": 16.0, "height": 16.0, "bond_number": 1000},
    "observables": {"trajectory_every": 3},
}


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    out = tmp_path_factory.mktemp("export") / "deposit.h5"
    res = loosepack.run(SCAN, out, progress=False, args=["--snapshots"])
    exe = loosepack.find_program()
    files = {}
    for fmt in ("xdmf", "extxyz"):
        done = subprocess.run([exe, "export", str(out), "--format", fmt, "--point", "0"],
                              capture_output=True, text=True, check=True)
        files[fmt] = done.stdout.split()
    return res, files


def snapshot(res, seed):
    with h5py.File(res.path, "r") as f:
        g = f["points/0000/members/snapshot_%d" % seed]
        return {k: g[k][()] for k in g}


def trajectory(res, seed):
    with h5py.File(res.path, "r") as f:
        g = f["points/0000/members/trajectory_%d" % seed]
        return {k: g[k][()] for k in g}


def test_export_names_every_file(exported):
    res, files = exported
    stem = res.path[:-len(".h5")]
    assert sorted(files["xdmf"]) == sorted(
        [stem + "_p0000_s%d%s.xmf" % (s, t) for s in (0, 1) for t in ("", "_trajectory")] +
        [stem + "_p0000_s%d_contacts.h5" % s for s in (0, 1)])
    assert len(files["extxyz"]) == 4


def export_copy(res, out, *args):
    """`loosepack export` of the result file copied to `out` (kept where it is already); the
    files it names."""
    if not out.exists():
        out.write_bytes(open(res.path, "rb").read())
    return subprocess.run([loosepack.find_program(), "export", str(out), *args],
                          capture_output=True, text=True, check=True).stdout.split()


def test_a_later_export_leaves_the_earlier_files_whole(exported, tmp_path):
    """Each snapshot's contact lines are in a file of its own: exporting one seed after another
    leaves the first seed's files as they were, and they still hold what its XDMF file names."""
    res, _ = exported
    out = tmp_path / "again.h5"
    first = export_copy(res, out, "--point", "0", "--seed", "0")
    before = {f: open(f, "rb").read() for f in first}
    export_copy(res, out, "--point", "0", "--seed", "1")
    assert {f: open(f, "rb").read() for f in first} == before
    xmf = [f for f in first if f.endswith("_s0.xmf")][0]
    side = [f for f in first if f.endswith("_s0_contacts.h5")][0]
    refs = re.findall(r"_contacts\.h5:(/[^<\s]+)", open(xmf).read())
    assert refs
    with h5py.File(side, "r") as h:
        for ref in refs:
            assert ref in h


def test_a_selection_the_file_lacks_is_refused_with_its_range(exported):
    res, _ = exported
    exe = loosepack.find_program()
    for option, value, message in (("--point", "7", "has the points 0000"),
                                   ("--seed", "5", "has the seeds 0 to 1")):
        done = subprocess.run([exe, "export", res.path, option, value], capture_output=True,
                              text=True)
        assert done.returncode == 2
        assert message in done.stderr


def test_a_name_with_a_colon_is_refused_for_xdmf_and_exported_as_extxyz(exported, tmp_path):
    """XDMF refers to the result file as FILE:/dataset, which ParaView splits at the first ':':
    such a name is refused (exit 2, nothing written); extended XYZ holds no reference."""
    res, _ = exported
    out = tmp_path / "run-10:00.h5"
    out.write_bytes(open(res.path, "rb").read())
    done = subprocess.run([loosepack.find_program(), "export", str(out), "--point", "0"],
                          capture_output=True, text=True)
    assert done.returncode == 2
    assert "its name holds ':'" in done.stderr
    assert sorted(os.listdir(tmp_path)) == ["run-10:00.h5"]
    assert export_copy(res, out, "--format", "extxyz", "--point", "0")


def test_a_directory_where_a_viewer_file_goes_is_refused_before_anything_is_written(exported,
                                                                                     tmp_path):
    res, _ = exported
    out = tmp_path / "dir.h5"
    out.write_bytes(open(res.path, "rb").read())
    (tmp_path / "dir_p0000_s1.xmf").mkdir()
    done = subprocess.run([loosepack.find_program(), "export", str(out), "--point", "0"],
                          capture_output=True, text=True)
    assert done.returncode == 2 and "dir_p0000_s1.xmf is not a file" in done.stderr
    assert sorted(os.listdir(tmp_path)) == ["dir.h5", "dir_p0000_s1.xmf"]


def damaged_copy(res, tmp_path, name, edit):
    """A copy of the result file with one member's datasets edited by `edit(group)`."""
    out = tmp_path / name
    out.write_bytes(open(res.path, "rb").read())
    with h5py.File(out, "r+") as f:
        edit(f["points/0000/members"])
    return out


def replace(group, name, values):
    del group[name]
    group[name] = values


@pytest.mark.parametrize("case, edit, message", [
    ("contact_i", lambda m: replace(m["snapshot_0"], "contact_i", np.full(
        m["snapshot_0/contact_i"].shape, 1e9)), "contact_i holds 1e+09, not a disk of the"),
    ("contact_j", lambda m: replace(m["snapshot_0"], "contact_j", np.full(
        m["snapshot_0/contact_j"].shape, -7.0)), "contact_j holds -7, not a disk of the"),
    ("y_e", lambda m: replace(m["snapshot_0"], "y_e", m["snapshot_0/y_e"][:2]),
     "snapshot_0/y_e has 2 values, x "),
    ("trajectory", lambda m: replace(m["trajectory_1"], "x", m["trajectory_1/x"][:1]),
     "trajectory_1/x has 1 values, time "),
    ("missing", lambda m: m["snapshot_1"].__delitem__("x"),
     "cannot open dataset /points/0000/members/snapshot_1/x"),
    ("renamed", lambda m: m.move("snapshot_1", "snapshot_one"),
     "/points/0000/members/snapshot_one: not a group name the program writes"),
    # Lengths right, values unreadable as numbers: found while the second member's file is built,
    # after the first member's.
    ("text", lambda m: replace(m["snapshot_1"], "y_e", np.array(
        ["x"] * len(m["snapshot_1/y_e"]), dtype=h5py.string_dtype())),
     "snapshot_1/y_e"),
])
def test_a_damaged_file_is_refused_and_nothing_is_written(exported, tmp_path, case, edit,
                                                           message):
    """Data no run writes (contact indices naming no disk, lengths that differ, a missing
    dataset, a member's group not named as the program names them, text for numbers) is invalid input (exit 2) naming the file and the dataset, for both formats, and no
    viewer file is written: each member's files are built before any is written."""
    res, _ = exported
    exe = loosepack.find_program()
    out = damaged_copy(res, tmp_path, case + ".h5", edit)
    for fmt in ("xdmf", "extxyz"):
        done = subprocess.run([exe, "export", str(out), "--format", fmt], capture_output=True,
                              text=True)
        assert done.returncode == 2, done.stderr
        assert str(out) + ": " in done.stderr and message in done.stderr, done.stderr
        assert "the file is damaged or was edited" in done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == [case + ".h5"]


def test_a_file_name_with_xml_markup_gives_well_formed_xdmf(exported, tmp_path):
    """The XDMF files name the result file they read: a name with &, < or > is escaped, so the
    files still parse as XML (ParaView's reader parses them so) and name the file as it is."""
    import xml.etree.ElementTree as ET
    res, _ = exported
    files = export_copy(res, tmp_path / "a&b<c>.h5", "--point", "0", "--seed", "0")
    xmf = [f for f in files if f.endswith(".xmf")]
    assert xmf
    for f in xmf:
        items = [e.text for e in ET.parse(f).iter("DataItem") if e.get("Format") == "HDF"]
        assert items and all(t.startswith(("a&b<c>.h5:", "a&b<c>_p0000_s0_contacts.h5:"))
                             for t in items), items


def test_a_seed_a_file_of_some_members_lacks_is_refused_with_what_it_holds(tmp_path):
    """A file of some members (here `--member 1`: seed 1 of point 0) has seed 0 in its scan's
    range but no snapshot of it: refused as a selection (exit 2), naming the snapshots it has."""
    out = tmp_path / "one.h5"
    loosepack.run(SCAN, out, progress=False, args=["--snapshots", "--member", "1"])
    exe = loosepack.find_program()
    done = subprocess.run([exe, "export", str(out), "--seed", "0"], capture_output=True,
                          text=True)
    assert done.returncode == 2
    assert "--seed 0: " in done.stderr and "only those of point 0000 seed 1" in done.stderr
    done = subprocess.run([exe, "export", str(out), "--seed", "1"], capture_output=True,
                          text=True, check=True)
    assert any(f.endswith("_p0000_s1.xmf") for f in done.stdout.split())


def test_paraview_reads_disks_contacts_and_forces(exported):
    pv = pytest.importorskip("paraview.simple",
                             reason="python3-paraview is not installed (scripts/install-deps.sh --test)")
    from paraview import servermanager
    res, files = exported
    snap = snapshot(res, 1)
    xmf = [f for f in files["xdmf"] if f.endswith("_s1.xmf")][0]
    data = servermanager.Fetch(pv.XDMFReader(FileNames=[xmf]))
    disks, contacts = data.GetBlock(0), data.GetBlock(1)
    n, nc = len(snap["x"]), len(snap["contact_i"])
    assert disks.GetNumberOfPoints() == n and disks.GetNumberOfCells() == n
    radius = disks.GetPointData().GetArray("radius")
    assert [radius.GetValue(k) for k in range(n)] == list(snap["radius"])
    dy = disks.GetPointData().GetArray("delta_y")
    assert np.allclose([dy.GetValue(k) for k in range(n)], snap["y_e"] - snap["y_i"])
    assert contacts.GetNumberOfCells() == nc
    normal = contacts.GetCellData().GetArray("normal")
    assert np.allclose([normal.GetValue(k) for k in range(nc)], snap["contact_normal"])
    # Each contact is a line from disk i's centre to disk j's (its periodic image nearest to i),
    # or to the floor below disk i; its length is the distance of the two centres, at most the
    # sum of the radii plus the cohesion range and the contact detection's reach.
    width = 16.0
    for c in range(nc):
        cell = contacts.GetCell(c)
        ends = np.array([contacts.GetPoint(cell.GetPointId(k))[:2] for k in range(2)])
        i, j = snap["contact_i"][c], snap["contact_j"][c]
        if j < 0:
            assert np.allclose(ends, [(snap["x"][i], snap["y_e"][i]), (snap["x"][i], 0.0)])
            continue
        dx = snap["x"][j] - snap["x"][i]
        dx -= width * np.round(dx / width)
        assert np.allclose(ends, [(snap["x"][i], snap["y_e"][i]),
                                  (snap["x"][i] + dx, snap["y_e"][j])])
        assert np.hypot(*(ends[1] - ends[0])) < snap["radius"][i] + snap["radius"][j] + 1.5


def test_paraview_steps_through_the_trajectory(exported):
    pv = pytest.importorskip("paraview.simple",
                             reason="python3-paraview is not installed (scripts/install-deps.sh --test)")
    from paraview import servermanager
    res, files = exported
    t = trajectory(res, 0)
    times = np.unique(t["time"])
    reader = pv.XDMFReader(FileNames=[f for f in files["xdmf"] if f.endswith("_s0_trajectory.xmf")][0])
    assert list(reader.TimestepValues) == list(times.astype(float))
    last = times[-1]
    reader.UpdatePipeline(float(last))
    grid = servermanager.Fetch(reader)
    at = t["time"] == last
    assert grid.GetNumberOfPoints() == at.sum()
    disk = grid.GetPointData().GetArray("disk")
    assert [disk.GetValue(k) for k in range(at.sum())] == list(t["disk"][at])


def test_extxyz_reads_back_with_ase(exported):
    ase_io = pytest.importorskip("ase.io", reason="python3-ase is not installed")
    res, files = exported
    snap = snapshot(res, 0)
    frames = ase_io.read([f for f in files["extxyz"] if f.endswith("_s0.extxyz")][0], index=":")
    assert len(frames) == 1
    atoms = frames[0]
    assert len(atoms) == len(snap["x"])
    assert np.allclose(atoms.positions[:, 0], snap["x"])
    assert np.allclose(atoms.positions[:, 1], snap["y_e"])
    assert np.allclose(atoms.arrays["radius"], snap["radius"])
    assert list(atoms.pbc) == [True, False, False]
    assert np.allclose(np.diag(atoms.cell), [16.0, 16.0, 1.0])
    t = trajectory(res, 0)
    steps = ase_io.read([f for f in files["extxyz"] if f.endswith("_s0_trajectory.extxyz")][0],
                        index=":")
    assert len(steps) == len(np.unique(t["time"]))
    assert sum(len(s) for s in steps) == len(t["x"])


def test_a_file_without_snapshots_is_refused(tmp_path):
    out = tmp_path / "plain.h5"
    loosepack.run({"system": {"width": 12.0, "height": 12.0, "bond_number": 0}}, out,
                  progress=False)
    done = subprocess.run([loosepack.find_program(), "export", str(out)], capture_output=True,
                          text=True)
    assert done.returncode == 1 and "--snapshots" in done.stderr


def test_a_result_file_where_a_viewer_file_goes_is_refused_and_kept(exported, tmp_path):
    """An earlier export's files are replaced, but a result file that happens to bear a viewer
    file's name (here seed 1's contacts sidecar) is refused before anything is written (exit 2),
    and stays as it was."""
    res, _ = exported
    exe = loosepack.find_program()
    out = tmp_path / "again.h5"
    out.write_bytes(open(res.path, "rb").read())
    subprocess.run([exe, "export", str(out)], capture_output=True, text=True, check=True)
    subprocess.run([exe, "export", str(out)], capture_output=True, text=True, check=True)
    for f in tmp_path.glob("again_*"):
        f.unlink()
    victim = tmp_path / "again_p0000_s1_contacts.h5"
    victim.write_bytes(open(res.path, "rb").read())
    done = subprocess.run([exe, "export", str(out)], capture_output=True, text=True)
    assert done.returncode == 2 and "is a loosepack result file" in done.stderr, done.stderr
    assert victim.read_bytes() == open(res.path, "rb").read()
    assert sorted(f.name for f in tmp_path.glob("again_*")) == [victim.name]


def test_a_member_without_dynamics_has_no_trajectory_to_export(tmp_path):
    """Protocol B deposits without dynamics: its trajectory groups hold no sample, and export
    writes no viewer file of them (a file of nothing else is refused, exit 1)."""
    scan = {"scan": {"protocol": "B", "seeds": 2},
            "system": {"width": 12.0, "height": 12.0},
            "observables": {"trajectory_every": 3}}
    exe = loosepack.find_program()
    plain = tmp_path / "plain.h5"
    loosepack.run(scan, plain, progress=False)
    with h5py.File(plain, "r") as f:
        assert len(f["points/0000/members/trajectory_0/time"]) == 0
    done = subprocess.run([exe, "export", str(plain)], capture_output=True, text=True)
    assert done.returncode == 1 and "no dynamics" in done.stderr
    assert not list(tmp_path.glob("plain_*"))
    snaps = tmp_path / "snaps.h5"
    loosepack.run(scan, snaps, progress=False, args=["--snapshots"])
    done = subprocess.run([exe, "export", str(snaps)], capture_output=True, text=True,
                          check=True)
    stem = str(snaps)[:-len(".h5")]
    assert sorted(done.stdout.split()) == sorted(
        [stem + "_p0000_s%d%s" % (s, t) for s in (0, 1) for t in (".xmf", "_contacts.h5")])
    # Its snapshots hold no contact: their XDMF has no contacts grid, whose empty dataset
    # ParaView's reader refuses (test_paraview_reads_a_deposit_without_contacts).
    with h5py.File(snaps, "r") as f:
        assert len(f["points/0000/members/snapshot_0/contact_i"]) == 0
    assert 'Name="contacts"' not in open(stem + "_p0000_s0.xmf").read()


def test_paraview_reads_a_deposit_without_contacts(tmp_path):
    """A protocol-B snapshot (no contacts): ParaView reads its one grid, the disks, and prints
    no error (an empty contacts grid made its XDMF reader fail)."""
    pytest.importorskip("paraview.simple",
                        reason="python3-paraview is not installed (scripts/install-deps.sh --test)")
    scan = {"scan": {"protocol": "B", "seeds": 1}, "system": {"width": 12.0, "height": 12.0}}
    res = loosepack.run(scan, tmp_path / "b.h5", progress=False, args=["--snapshots"])
    subprocess.run([loosepack.find_program(), "export", res.path], capture_output=True,
                   check=True)
    with h5py.File(res.path, "r") as f:
        n = len(f["points/0000/members/snapshot_0/x"])
    read = ("from paraview import simple, servermanager\n"
            "data = servermanager.Fetch(simple.XDMFReader(FileNames=[%r]))\n"
            "print(data.GetNumberOfBlocks(), data.GetBlock(0).GetNumberOfPoints())\n"
            % str(tmp_path / "b_p0000_s0.xmf"))
    # In a process of its own: the reader's errors go to the C level's stderr.
    done = subprocess.run([sys.executable, "-c", read], capture_output=True, text=True)
    assert done.stdout.split() == ["1", str(n)] and "rror" not in done.stderr, done.stderr


def test_the_exported_times_are_the_stored_ones_to_the_last_digit(exported, tmp_path):
    """A trajectory's time counts disks deposited (A) or steps (C), which reach millions in a
    long collapse: both formats write each time as stored, to its seventh digit and beyond, so
    that no two samples share one."""
    res, _ = exported
    out = tmp_path / "late.h5"
    out.write_bytes(open(res.path, "rb").read())
    with h5py.File(out, "r+") as f:
        t = f["points/0000/members/trajectory_0/time"]
        t[...] = t[()] + 1234567.0
        times = list(np.unique(t[()]))
    exe = loosepack.find_program()
    for fmt, pattern in (("xdmf", r'<Time Value="([^"]+)"'), ("extxyz", r"Time=(\S+)")):
        names = subprocess.run([exe, "export", str(out), "--format", fmt, "--point", "0",
                                "--seed", "0"], capture_output=True, text=True,
                               check=True).stdout.split()
        name = [n for n in names if "trajectory" in n][0]
        assert [float(v) for v in re.findall(pattern, open(name).read())] == times, fmt


def test_a_failed_members_snapshot_is_exported_as_its_failure_only(tmp_path, monkeypatch):
    """With --snapshots a failed member (LOOSEPACK_INJECT_NAN=1: member 1) gets no snapshot_1,
    only failure_1; a file written before 2026-12-02 holds a snapshot_1 too (the same state,
    copied in here), which is no deposit: export writes the failure snapshot, and the finished
    member's deposit."""
    monkeypatch.setenv("LOOSEPACK_INJECT_NAN", "1")
    scan = {"scan": {"seeds": 2}, "system": {"width": 12.0, "height": 12.0, "bond_number": 30}}
    res = loosepack.run(scan, tmp_path / "fail.h5", progress=False, args=["--snapshots"])
    with h5py.File(res.path, "r+") as f:
        members = f["points/0000/members"]
        assert {"snapshot_0", "failure_1"} <= set(members) and "snapshot_1" not in members
        members.copy("failure_1", "snapshot_1")
    stem = res.path[:-len(".h5")]
    for fmt, ext in (("xdmf", ".xmf"), ("extxyz", ".extxyz")):
        names = subprocess.run([loosepack.find_program(), "export", res.path, "--format", fmt],
                               capture_output=True, text=True, check=True).stdout.split()
        assert sorted(n for n in names if n.endswith(ext)) == [
            stem + "_p0000_s0" + ext, stem + "_p0000_s1_failure" + ext], fmt
