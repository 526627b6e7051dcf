"""tools/compare.py: a file against itself agrees in every quantity; a run at another Bond
number differs where the physics says it must (the volume fraction, the avalanche size); its
two-sample event test on counts drawn from one distribution and from two; events compared by
the members' scatter, where members differ; and the histogram shapes, which agree when one
shape fits both files."""

import json
import math
import os
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest

import loosepack
from rates import binomial_quantile
from script_module import load_script

HERE = os.path.dirname(os.path.abspath(__file__))
TOOL = os.path.join(HERE, "..", "..", "tools", "compare.py")
compare = load_script(TOOL)


def scan(bond_number):
    return {"scan": {"name": "compare", "seed": 5, "seeds": 6, "protocol": "A"},
            "system": {"width": 16.0, "height": 24.0, "bond_number": bond_number}}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("compare")
    cohesive = loosepack.run(scan(100.0), d / "bo100.h5", progress=False)
    # Bo = 1: barely cohesive, so the disks roll into a much denser packing (nu_lower_half
    # about 0.7 against 0.5, docs/PERFORMANCE.md "Effects on and off") and move further.
    weak = loosepack.run(scan(1.0), d / "bo1.h5", progress=False)
    return d, cohesive.path, weak.path


def run_tool(a, b, *extra):
    return subprocess.run([sys.executable, TOOL, str(a), str(b), *extra],
                          capture_output=True, text=True)


def test_a_file_agrees_with_itself(runs):
    d, cohesive, _ = runs
    out = run_tool(cohesive, cohesive, "--json", d / "self.jsonl")
    assert out.returncode == 0, out.stdout + out.stderr
    rows = json.loads(open(d / "self.jsonl").read().splitlines()[0])["rows"]
    names = {r["quantity"] for r in rows}
    assert {"nu_lower_half", "mean abs(Delta y) [R]", "nu(y)", "Delta y(y_e): c",
            "events: distribution of steps"} <= names
    assert all(r["distance"] == 0 for r in rows)


def test_another_bond_number_differs(runs):
    d, cohesive, weak = runs
    out = run_tool(cohesive, weak, "--json", d / "bo.jsonl")
    assert out.returncode == 1, out.stdout + out.stderr
    rows = {r["quantity"]: r for r in json.loads(open(d / "bo.jsonl").read())["rows"]}
    assert not rows["nu_lower_half"]["within"]
    with h5py.File(cohesive) as f:  # the scalars' numbers, not only their text
        assert rows["nu_lower_half"]["a_value"] == f["points/0000"].attrs["nu_lower_half_mean"]
    assert not rows["nu(y)"]["within"]
    assert not rows["mean abs(Delta y) [R]"]["within"]  # weaker cohesion: larger avalanches
    assert "| nu_lower_half |" in out.stdout and "NO |" in out.stdout
    # Points paired by their index that differ in a scan parameter are said to.
    assert "paired by their index" in out.stdout
    assert "(the two points differ in bond_number" in out.stdout
    assert "differ in" not in run_tool(cohesive, cohesive).stdout


def test_points_pair_up_by_their_parameters(runs, tmp_path):
    """A file of two points against one that holds only the second: the second pairs with the
    other file's only point (not the first, which has the same index), and the first is named
    as not compared. Another protocol, or a file that is not a result, is refused (exit 2)."""
    d, cohesive, weak = runs
    both = tmp_path / "both.h5"
    with h5py.File(both, "w") as f, h5py.File(weak) as w, h5py.File(cohesive) as c:
        for k, v in c.attrs.items():
            f.attrs[k] = v
        f.copy(c["scan_text"], "scan_text")
        f.copy(w["points/0000"], "points/0000")  # Bo = 1 first, then Bo = 100
        f.copy(c["points/0000"], "points/0001")
    out = run_tool(both, cohesive)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "point 0001 / 0000:" in out.stdout and "paired by their parameters" in out.stdout
    assert "the points 0000 of" in out.stderr and "not compared" in out.stderr
    ballistic = loosepack.run({"scan": {"name": "b", "seeds": 2, "protocol": "B"},
                               "system": {"width": 16.0, "height": 24.0}},
                              tmp_path / "b.h5", progress=False)
    out = run_tool(ballistic.path, cohesive)
    assert out.returncode == 2 and "protocol B" in out.stderr and "not comparable" in out.stderr
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = [1.0]
    out = run_tool(other, cohesive)
    assert out.returncode == 2 and "not a loosepack result file" in out.stderr


def test_collapses_compare_their_densities_and_definitions_are_named(tmp_path):
    """Protocol C's initial density and relative increase are compared; a file whose bands
    define the observables otherwise (here lower_half_from) is said to, beside its rows."""
    c = {"scan": {"name": "c", "seeds": 4, "protocol": "C"},
         "system": {"width": 16.0, "height": 24.0, "bond_number": 1000.0, "capture_radius": 2.0},
         "observables": {"lower_half_from": 2.0}}
    a = loosepack.run(c, tmp_path / "a.h5", progress=False)
    c["observables"]["lower_half_from"] = 4.0
    b = loosepack.run(c, tmp_path / "b.h5", progress=False)
    out = run_tool(a.path, a.path)
    assert "| nu_i |" in out.stdout and "| dnu/nu_i |" in out.stdout, out.stdout
    assert "define observables differently" not in out.stdout
    out = run_tool(a.path, b.path)
    assert "the files define observables differently: lower_half_from" in out.stdout, out.stdout


def test_a_parameter_one_point_lacks_does_not_pair_it_by_parameters(runs, tmp_path):
    """A point without its Bond number attribute (an edited or damaged file) is not taken for a
    point of the other file's Bond number: the index pairs them, and the note says what lacks."""
    d, cohesive, weak = runs
    unnamed = tmp_path / "unnamed.h5"
    unnamed.write_bytes(open(weak, "rb").read())
    with h5py.File(unnamed, "r+") as f:
        del f["points/0000"].attrs["bond_number"]
    out = run_tool(unnamed, cohesive)
    assert "paired by their index" in out.stdout, out.stdout
    assert "(the two points differ in bond_number (absent from A)" in out.stdout, out.stdout


def test_a_quantity_one_file_lacks_is_said_and_damaged_input_refused(runs, tmp_path):
    """A group one file holds and the other lacks (a damaged or edited file) is a row not
    judged, naming the file without it, instead of dropping out of the comparison unseen;
    --paired without per-member datasets and --json into a missing directory exit 2 with a
    message, not a traceback."""
    d, cohesive, _ = runs
    lacking = tmp_path / "lacking.h5"
    lacking.write_bytes(open(cohesive, "rb").read())
    with h5py.File(lacking, "r+") as f:
        del f["points/0000/nu"]
        del f["points/0000/members"]
    out = run_tool(cohesive, lacking)
    assert "| nu(y) | present | - | not judged (absent from B) |" in out.stdout, out.stdout
    assert "1 not judged" in out.stdout and out.returncode == 0, out.stdout + out.stderr
    out = run_tool(cohesive, lacking, "--paired")
    assert out.returncode == 2 and "B holds no per-member datasets" in out.stderr, out.stderr
    out = run_tool(cohesive, cohesive, "--json", tmp_path / "nodir" / "x.jsonl")
    assert out.returncode == 2 and "its directory does not exist" in out.stderr, out.stderr


def test_a_point_of_one_member_is_not_judged(tmp_path):
    """One member gives no standard error: its scalars are not judged (not counted as
    differing), and a file compared with itself exits 0."""
    one = loosepack.run({"scan": {"name": "one", "seeds": 1, "protocol": "A"},
                         "system": {"width": 16.0, "height": 16.0, "bond_number": 100.0}},
                        tmp_path / "one.h5", progress=False)
    out = run_tool(one.path, one.path, "--json", tmp_path / "one.jsonl")
    assert out.returncode == 0, out.stdout + out.stderr
    rows = {r["quantity"]: r for r in json.loads(open(tmp_path / "one.jsonl").read())["rows"]}
    assert rows["nu_lower_half"]["within"] is None and "not judged" in rows["nu_lower_half"]["detail"]
    assert "not judged" in out.stdout


def test_one_members_histogram_shape_and_events_are_not_judged(tmp_path):
    """Single members of two scan seeds: the histogram's shape verdicts rest on Poisson's errors
    and the events' mean size has no scatter over members to take an error from: neither is
    judged (they read as differences between two draws of one ensemble)."""
    files = []
    for seed in (2027, 2028):
        files.append(loosepack.run({"scan": {"name": "one", "seed": seed, "seeds": 1,
                                             "protocol": "A"},
                                    "system": {"width": 24.0, "height": 24.0,
                                               "bond_number": 1.0}},
                                   tmp_path / f"one{seed}.h5", progress=False).path)
    run_tool(*files, "--json", tmp_path / "one.jsonl")
    rows = {r["quantity"]: r for r in json.loads(open(tmp_path / "one.jsonl").read())["rows"]}
    shape = rows["abs(Delta y) histogram (cut): shape"]
    assert shape["within"] is None and "members' scatter" in shape["detail"], shape
    events = rows["events: mean log10(disks moved)"]
    assert events["within"] is None and "one member" in events["detail"], events


def test_nothing_moved_is_not_judged(tmp_path):
    """Bo = 1e4 in a low box: the disks move by round-off (far below event_threshold), in
    amounts that depend on the solver's tolerance: two tolerances' mean abs(Delta y) and
    profile lines are not judged, as the program's fits across points leave such points out."""
    files = []
    for tolerance in (1e-3, 1e-4):
        files.append(loosepack.run({"scan": {"name": "still", "seed": 3, "seeds": 6,
                                             "protocol": "A"},
                                    "system": {"width": 24.0, "height": 16.0,
                                               "bond_number": 1e4},
                                    "solver": {"tolerance": tolerance}},
                                   tmp_path / f"still{tolerance}.h5", progress=False).path)
    with h5py.File(files[0]) as f:
        assert f["points/0000"].attrs["mean_abs_dy_mean"] < f["settings"].attrs["event_threshold"]
    run_tool(*files, "--json", tmp_path / "still.jsonl")
    rows = json.loads(open(tmp_path / "still.jsonl").read())["rows"]
    moves = [r for r in rows if r["quantity"].startswith(("mean abs(Delta y)", "Delta y("))]
    assert moves and all(r["within"] is None and "nothing moved" in r["detail"] for r in moves)


def test_paired_members_tell_a_shift_their_scatter_hides(runs, tmp_path):
    """--paired: a shift of every member's nu_lower_half by a third of the ensemble's standard
    error is inside the combined errors of two independent ensembles, and far outside the
    scatter of the members' differences; the profile fits of the same members differ by zero;
    files of other scan seeds are refused."""
    d, cohesive, _ = runs
    shifted = tmp_path / "shifted.h5"
    shutil.copy(cohesive, shifted)
    rng = np.random.default_rng(11)
    with h5py.File(shifted, "r+") as f:
        p = f["points/0000"]
        shift = p.attrs["nu_lower_half_sem"] / 3
        per_member = p["members/nu_lower_half"]
        per_member[...] = per_member[()] + shift + rng.normal(0, shift / 100, per_member.shape)
        p.attrs["nu_lower_half_mean"] = per_member[()].mean()
    def rows(name, *extra):
        run_tool(cohesive, shifted, "--json", tmp_path / name, *extra)
        return {r["quantity"]: r for r in json.loads(open(tmp_path / name).read())["rows"]}

    unpaired, paired = rows("unpaired.jsonl"), rows("paired.jsonl", "--paired")
    assert unpaired["nu_lower_half"]["within"] and unpaired["nu_lower_half"]["distance"] < 0.5
    assert not paired["nu_lower_half"]["within"] and paired["nu_lower_half"]["distance"] > 50
    # The record keeps the paired difference B - A (the shift, give or take its 1 % noise) and
    # its error (the noise's standard error over the members).
    assert paired["nu_lower_half"]["paired_difference"] == pytest.approx(shift, rel=0.05)
    assert 0 < paired["nu_lower_half"]["paired_error"] < shift / 20
    assert "paired_difference" not in unpaired["nu_lower_half"]
    assert paired["Delta y(y_e): c"]["distance"] == 0 and "(paired)" in paired[
        "Delta y(y_e): c"]["detail"]
    assert paired["mean abs(Delta y) [R]"]["distance"] == 0 and "(paired)" in paired[
        "mean abs(Delta y) [R]"]["detail"]
    # A member without a value in one file (a band its collapse left empty: NaN) drops out of
    # the pairs, as it does from the mean: the shift is still found, not an infinite distance.
    with h5py.File(shifted, "r+") as f:
        per_member = f["points/0000/members/nu_lower_half"]
        values = per_member[()]
        values[0] = math.nan
        per_member[...] = values
    paired = rows("paired_nan.jsonl", "--paired")
    assert math.isfinite(paired["nu_lower_half"]["distance"])
    assert paired["nu_lower_half"]["distance"] > 50
    assert paired["nu_lower_half"]["paired_difference"] == pytest.approx(shift, rel=0.05)
    other = tmp_path / "other_seed.h5"
    shutil.copy(cohesive, other)
    with h5py.File(other, "r+") as f:
        f.attrs["seed"] = f.attrs["seed"] + 1
    out = run_tool(cohesive, other, "--paired")
    assert out.returncode == 2 and "scan seeds or seed counts differ" in out.stderr, out.stderr
    # Three members failed in one file (3 of 6 left in both): that point is compared unpaired,
    # and says so, where the whole comparison stopped.
    failing = tmp_path / "failing.h5"
    shutil.copy(shifted, failing)
    with h5py.File(failing, "r+") as f:
        failure = f["points/0000/members/failure"]
        failure[...] = np.array([6, 6, 6, 0, 0, 0], dtype=failure.dtype)
    out = run_tool(cohesive, failing, "--paired", "--json", tmp_path / "few.jsonl")
    assert out.returncode in (0, 1), out.stderr
    assert "fewer than 4 members finished in both: compared unpaired" in out.stderr
    few = {r["quantity"]: r for r in json.loads(open(tmp_path / "few.jsonl").read())["rows"]}
    assert "paired_difference" not in few["nu_lower_half"]


def test_paired_collapse_compares_the_increase_member_by_member(tmp_path):
    """Protocol C: every member's final density 1 % higher is found in dnu/nu_i by the members'
    differences (from nu_lower_half / nu_i - 1 of each), as in nu_lower_half; unpaired the
    members' scatter hides it."""
    c = loosepack.run({"scan": {"name": "c", "seeds": 6, "protocol": "C"},
                       "system": {"width": 24.0, "height": 40.0, "bond_number": 1000.0,
                                  "capture_radius": 2.0}}, tmp_path / "c.h5", progress=False)
    denser = tmp_path / "denser.h5"
    shutil.copy(c.path, denser)
    with h5py.File(denser, "r+") as f:
        p = f["points/0000"]
        nu = p["members/nu_lower_half"]
        nu[...] = nu[()] * 1.01
        increase = nu[()] / p["members/nu_initial"][()] - 1
        p.attrs["nu_lower_half_mean"] = nu[()].mean()
        p.attrs["relative_increase_mean"] = increase.mean()
    def rows(name, *extra):
        run_tool(c.path, denser, "--json", tmp_path / name, *extra)
        return {r["quantity"]: r for r in json.loads(open(tmp_path / name).read())["rows"]}

    paired, unpaired = rows("paired.jsonl", "--paired"), rows("unpaired.jsonl")
    assert "(paired)" in paired["dnu/nu_i"]["detail"] and not paired["dnu/nu_i"]["within"]
    assert unpaired["dnu/nu_i"]["within"]


def test_paired_fits_go_through_the_bins_both_files_fill(runs, tmp_path):
    """B is A with one member's disks of one profile bin gone (that bin drops out of B's fit):
    the paired difference of the fits goes through the bins both fill, so equal data elsewhere
    give a difference of 0 (through each file's own bins it was not)."""
    d, cohesive, _ = runs
    holed = tmp_path / "holed.h5"
    shutil.copy(cohesive, holed)
    with h5py.File(holed, "r+") as f:
        count = f["points/0000/avalanche_by_ye/member_count"]
        c = count[()]
        filled = np.flatnonzero((c > 0).all(axis=0) & (c.sum(axis=0) >= 10))
        c[0, filled[len(filled) // 2]] = 0
        count[...] = c
    run_tool(cohesive, holed, "--paired", "--json", tmp_path / "holed.jsonl")
    rows = {r["quantity"]: r for r in json.loads(open(tmp_path / "holed.jsonl").read())["rows"]}
    for k in "abc":
        assert rows[f"Delta y(y_e): {k}"]["paired_difference"] == 0, rows[f"Delta y(y_e): {k}"]


def test_paired_with_a_file_without_member_profiles_compares_the_fits_unpaired(runs, tmp_path):
    """A file of before 2026-11-24 holds no per-member profile rows: with --paired, in either
    order, its profile fits are compared unpaired (it was called damaged when second)."""
    d, cohesive, _ = runs
    old = tmp_path / "old.h5"
    shutil.copy(cohesive, old)
    with h5py.File(old, "r+") as f:
        for by in ("yi", "ye"):
            del f[f"points/0000/avalanche_by_{by}/member_mean"]
    for a, b in ((cohesive, old), (old, cohesive)):
        out = run_tool(a, b, "--paired", "--json", tmp_path / "p.jsonl")
        assert out.returncode == 0, out.stdout + out.stderr
        rows = json.loads(open(tmp_path / "p.jsonl").read().splitlines()[-1])["rows"]
        fits = [r for r in rows if r["quantity"].startswith("Delta y(")]
        assert fits and all("paired" not in r["detail"] for r in fits)


def test_paired_members_are_matched_by_seed_in_files_of_some_members(tmp_path):
    """A file of some members (`--finished-only`, a shard) pairs with a whole run's by seed index:
    the masks select the seeds finished in both, in the same order; with fewer than 4 the point is
    compared unpaired (members_in_both says why)."""
    def point(name, seeds, failures):
        f = h5py.File(tmp_path / name, "w")
        f.attrs["seed"], f.attrs["seeds"] = 7, 6
        f["points/0000/members/seed_index"] = np.array(seeds, dtype=np.int64)
        f["points/0000/members/failure"] = np.array(failures, dtype=np.int64)
        return f, f["points/0000"]
    fa, whole = point("whole.h5", [0, 1, 2, 3, 4, 5], [0, 0, 0, 0, 6, 0])
    fb, some = point("some.h5", [0, 2, 3, 4, 5], [0, 0, 0, 0, 0])
    with fa, fb:
        (in_a, in_b), why = compare.members_in_both(whole, some)
        assert why == ""
        assert whole["members/seed_index"][()][in_a].tolist() == [0, 2, 3, 5]
        assert some["members/seed_index"][()][in_b].tolist() == [0, 2, 3, 5]
    fa, whole = point("whole2.h5", [0, 1, 2, 3, 4, 5], [0] * 6)
    fb, some = point("some2.h5", [1, 4, 5], [0, 0, 0])
    with fa, fb:
        both, why = compare.members_in_both(whole, some)
        assert both is None and why == "fewer than 4 members finished in both"


def test_files_of_some_members_pair_with_the_whole_run(runs, tmp_path):
    """--paired of a whole run against the file of its first 5 members (a run stopped by an error
    at the sixth, then `--resume --finished-only`): the 5 pair by seed, and as the same members
    give the same results bit for bit, every paired difference is zero. Against one shard's file
    (3 of the 6 members) the point is compared unpaired, and says so."""
    d, cohesive, _ = runs
    exe = loosepack.find_program()
    toml = tmp_path / "scan.toml"
    shutil.copy(os.path.splitext(str(cohesive))[0] + ".toml", toml)
    some = tmp_path / "some.h5"
    env = dict(os.environ, LOOSEPACK_INJECT_ERROR="5")
    stopped = subprocess.run([exe, "run", str(toml), "-o", str(some), "-q", "--batch-size", "1"],
                             env=env, capture_output=True, text=True)
    assert stopped.returncode == 1, stopped.stderr
    subprocess.run([exe, "run", str(toml), "-o", str(some), "--resume", "--finished-only", "-q"],
                   check=True, capture_output=True, text=True)
    with h5py.File(some, "r") as f:
        assert f["points/0000/members/seed_index"][()].tolist() == [0, 1, 2, 3, 4]
    out = run_tool(cohesive, some, "--paired", "--json", tmp_path / "some.jsonl")
    assert out.returncode == 0, out.stdout + out.stderr
    rows = {r["quantity"]: r for r in json.loads(open(tmp_path / "some.jsonl").read())["rows"]}
    for q in ("nu_lower_half", "mean abs(Delta y) [R]", "Delta y(y_e): c"):
        assert "(paired)" in rows[q]["detail"] and rows[q]["distance"] == 0, rows[q]
    assert rows["nu_lower_half"]["paired_difference"] == 0
    shard = loosepack.run(scan(100.0), tmp_path / "shard.h5", progress=False,
                          args=["--shard", "0/2"])
    out = run_tool(cohesive, shard.path, "--paired")
    assert out.returncode in (0, 1), out.stderr
    assert "fewer than 4 members finished in both: compared unpaired" in out.stderr, out.stderr


def test_a_refused_point_leaves_no_output(runs, tmp_path):
    """Two points, the second without the per-member datasets --paired needs: refused (exit 2)
    naming both files, before the first point's table is printed or its JSON line written."""
    d, cohesive, _ = runs
    a, b = tmp_path / "a.h5", tmp_path / "b.h5"
    for path in (a, b):
        shutil.copy(cohesive, path)
        with h5py.File(path, "r+") as f:
            f.copy("points/0000", "points/0001")
            f["points/0001"].attrs["height"] = 99.0
    with h5py.File(b, "r+") as f:
        del f["points/0001/members/failure"]
    out = run_tool(a, b, "--paired", "--json", tmp_path / "out.jsonl")
    assert out.returncode == 2, out.stdout + out.stderr
    assert "point 0001 of" in out.stderr and str(a) in out.stderr and str(b) in out.stderr
    assert out.stdout == "" and not (tmp_path / "out.jsonl").exists()


def test_unusable_input_is_named():
    out = run_tool("/nonexistent/a.h5", "/nonexistent/b.h5")
    assert out.returncode == 2 and "a.h5" in out.stderr
    out = run_tool("/nonexistent/a.h5", "/nonexistent/b.h5", "--sigma", "-1")
    assert out.returncode == 2 and "positive number of standard errors" in out.stderr


def test_homogeneity_tells_one_distribution_from_two():
    rng = np.random.default_rng(3)
    p = np.array([0.4, 0.3, 0.15, 0.1, 0.05])
    same = [compare.homogeneity(rng.multinomial(400, p).astype(float),
                                rng.multinomial(600, p).astype(float)) for _ in range(200)]
    # The statistic has its chi2 distribution: mean dof (the mean of 200 chi2 of 4 dof has a
    # standard error sqrt(2 * 4 / 200) = 0.2; 0.6 is three of them), and the 99 % bound crossed
    # as often as a 1 % level allows.
    assert np.mean([c for c, _ in same]) == pytest.approx(4, abs=3 * math.sqrt(8 / 200))
    assert sum(c > compare.chi2_quantile99(k) for c, k in same) <= binomial_quantile(200, 0.01)
    q = np.array([0.2, 0.2, 0.2, 0.2, 0.2])
    chi2, dof = compare.homogeneity(rng.multinomial(400, p).astype(float),
                                    rng.multinomial(600, q).astype(float))
    assert chi2 > compare.chi2_quantile99(dof)
    # Sparse tails are merged until each bin expects 5 events from each sample.
    chi2, dof = compare.homogeneity(np.array([50.0, 30, 1, 0, 1]), np.array([60.0, 25, 0, 1, 0]))
    assert dof == 1  # the three sparse bins join the 30 and 25 events: two bins


def test_member_fractions_of_equal_ensembles_are_rejected_once_in_a_hundred():
    """Two files of 4 members from one distribution, each member's counts over 8 bins drawn
    with its own probabilities (members differ, as avalanche-prone ones do): the fractions' chi2
    crosses its 99 % bound about once in a hundred. Summing the plain z^2, each error from 4
    members' scatter, crosses it 13 % of the time with these draws."""
    rng = np.random.default_rng(8)
    p = np.array([0.3, 0.2, 0.15, 0.12, 0.1, 0.07, 0.04, 0.02])

    def members():
        return np.array([rng.multinomial(300, rng.dirichlet(60 * p)) for _ in range(4)])

    trials = 500
    rejected = 0
    for _ in range(trials):
        (row,) = compare.fractions("sizes", members(), members(), len(p), "events")
        rejected += not row.within
    assert rejected <= binomial_quantile(trials, 0.01), rejected


def test_fractions_of_members_whose_bins_move_together_are_bounded_by_splits_of_the_members():
    """Two files of 8 members from one distribution, each member's probabilities tilted by a
    smooth random field over 12 bins (neighbouring bins move together, as the bins of one
    avalanche-prone member do): the bound from splits of the members is crossed about once in a
    hundred (4 of 300 for this seed), the chi2's own 99 % quantile about 5 % of the time (15)."""
    rng = np.random.default_rng(3)
    p = np.exp(-np.arange(12) / 3.0)
    p /= p.sum()

    def members():
        rows = []
        for _ in range(8):
            e = np.empty(12)
            e[0] = rng.normal()
            for k in range(1, 12):
                e[k] = 0.95 * e[k - 1] + 0.312 * rng.normal()
            q = p * np.exp(0.6 * e)
            rows.append(rng.multinomial(400, q / q.sum()))
        return np.array(rows)

    trials, rejected, nominal = 300, 0, 0
    for _ in range(trials):
        (row,) = compare.fractions("sizes", members(), members(), len(p), "events")
        assert "bound from splits of the members" in row.detail
        rejected += not row.within
        dof = int(row.detail.split(" for ")[1].split()[0])  # "chi2 X for DOF (bound ..."
        nominal += row.distance > compare.chi2_quantile99(dof)
    assert rejected <= binomial_quantile(trials, 0.01), rejected
    assert nominal > rejected, (nominal, rejected)


def test_mean_log_of_binned_values():
    edges = np.array([1.0, 10.0, 100.0])
    m, e = compare.mean_log(edges, np.array([10.0, 10.0]))
    assert m == pytest.approx(1.0)  # bin centres 0.5 and 1.5 in log10
    assert e == pytest.approx(math.sqrt(20 * 0.25 / 19 / 20))


def event_point(f, name, rng, large, members=16, events=400):
    """A point whose members each have `events` avalanche events of 1 or 100 disks (bins 12 and
    20 of the program's logarithmic bins), a member's share of large ones drawn from `large`:
    members differ, as avalanche-prone members do, so the events are not independent draws."""
    edges = 10.0 ** (-3.0 + np.arange(33) / 4.0)
    rows = np.zeros((members, 32))
    for row in rows:
        n_large = rng.binomial(events, rng.choice(large))
        row[20], row[12] = n_large, events - n_large
    e = f.create_group(f"{name}/events")
    e["edges"], e["moved_counts"], e["member_moved_counts"] = edges, rows.sum(axis=0), rows
    e["steps_counts"], e["member_steps_counts"] = rows.sum(axis=0), rows
    return f[name]


def test_events_compared_by_the_members_scatter(tmp_path):
    import h5py
    rng = np.random.default_rng(11)
    member_alarms = pooled_alarms = 0
    with h5py.File(tmp_path / "events.h5", "w") as f:
        for k in range(20):  # pairs of ensembles of one process
            a = event_point(f, f"a{k}", rng, (0.1, 0.6))
            b = event_point(f, f"b{k}", rng, (0.1, 0.6))
            # At 3 sigma (the mean, 0.27 %) and the chi2's 99 % bounds (the two distributions)
            # a pair differs by chance at most 2.3 % of the time.
            member_alarms += not all(r.within for r in compare.events(a, b, 3.0))
            chi2, dof = compare.homogeneity(a["events/moved_counts"][()],
                                            b["events/moved_counts"][()])
            pooled_alarms += chi2 > compare.chi2_quantile99(dof)
        # Counted as independent, most pairs of one process would differ.
        assert member_alarms <= binomial_quantile(20, 0.0227) and pooled_alarms >= 10, (
            member_alarms, pooled_alarms)
        c = event_point(f, "c", rng, (0.5, 0.95))  # more large events: every row differs
        rows = list(compare.events(a, c, 3.0))
        assert len(rows) == 3 and not any(r.within for r in rows), [r.record() for r in rows]


def test_events_all_in_one_bin_are_not_judged(tmp_path):
    """A side whose every event lies in one bin of sizes (3 events of 2 disks) has a mean log10
    with a jackknife error of 0, which is the bins' doing, not a precision: not judged, where an
    error of 0 would put any difference at infinitely many sigma."""
    import h5py
    rng = np.random.default_rng(5)
    with h5py.File(tmp_path / "one_bin.h5", "w") as f:
        a = event_point(f, "a", rng, (0.1, 0.6))
        b = event_point(f, "b", rng, (0.0,), members=3, events=1)  # each member: one small event
        assert compare.mean_log(b["events/edges"][()], b["events/moved_counts"][()],
                                b["events/member_moved_counts"][()])[1] == 0
        row = next(compare.events(a, b, 3.0))
        assert row.name == "events: mean log10(disks moved)"
        assert math.isnan(row.distance) and "not judged" in row.detail


def shape_point(f, name, preferred, gaussian_chi2, exponential_chi2, dof=20):
    """A point whose cut histogram has the two fits with these chi2 (no per-member counts)."""
    cut = f.create_group(f"{name}/abs_dy_histogram/shape_cut")
    cut.attrs["preferred"] = preferred
    for shape, chi2 in (("gaussian", gaussian_chi2), ("exponential", exponential_chi2)):
        g = cut.create_group(shape)
        g.attrs.update(valid=1.0, chi2=chi2, dof=float(dof))
    return f[name]


def test_histogram_shapes_agree_when_one_shape_fits_both(tmp_path):
    import h5py
    bound = compare.chi2_quantile99(20)  # 37.6
    with h5py.File(tmp_path / "shapes.h5", "w") as f:
        a = shape_point(f, "a", "exponential", 21.0, 20.0)
        b = shape_point(f, "b", "gaussian", 25.0, bound + 5)  # the Gaussian fits both
        c = shape_point(f, "c", "gaussian", 18.0, bound + 30)
        d = shape_point(f, "d", "exponential", bound + 30, 19.0)  # no shape fits c and d
        e = shape_point(f, "e", "neither", bound + 9, bound + 8)
        verdict = lambda p, q: next(compare.histogram(p, q)).within
        assert verdict(a, b) and verdict(b, c) and verdict(e, e)
        assert not verdict(c, d) and not verdict(c, e)
        # Files from 2026-12-03 on judge each shape themselves (attribute `acceptable`, by its
        # next two terms where the members give errors), whatever its chi2.
        g = shape_point(f, "g", "gaussian", bound + 30, bound + 40)
        h = shape_point(f, "h", "neither", bound + 30, 19.0)
        for p, gaussian_ok in ((g, 1.0), (h, 0.0)):
            p["abs_dy_histogram/shape_cut/gaussian"].attrs["acceptable"] = gaussian_ok
            p["abs_dy_histogram/shape_cut/exponential"].attrs["acceptable"] = 0.0
        assert verdict(g, c) and not verdict(h, d) and not verdict(g, h)


def test_claims_histogram_fits_are_the_programs(runs):
    """tools/claims.py fits the cut histogram's bands itself (the tail beyond 2 R at Bo = 0): over
    the whole band its fits are the program's, coefficients, jackknife errors and next terms."""
    claims = load_script(os.path.join(HERE, "..", "..", "tools", "claims.py"))
    _, cohesive, _ = runs
    with h5py.File(cohesive, "r") as f:
        point = f["points/0000"]
        hist = claims.Histogram(point["abs_dy_histogram"], str(cohesive))
        assert hist.members == 6
        for degree, shape in ((1, "exponential"), (2, "gaussian")):
            g = point[f"abs_dy_histogram/shape_cut/{shape}"]
            coef, err, chi2, _, ts = hist.fit(degree, np.ones(hist.centre.size, bool))
            assert np.allclose(coef, g["coef"][()], rtol=1e-7, atol=1e-9), (shape, coef)
            assert np.allclose(err, g["error"][()], rtol=1e-6), (shape, err)
            assert chi2 == pytest.approx(g.attrs["chi2"], rel=1e-6)
            assert ts == pytest.approx((g.attrs["next_term_t"], g.attrs["second_term_t"]),
                                       rel=1e-5)


def test_scalars_give_the_ratio_of_their_values(runs):
    d, cohesive, weak = runs
    run_tool(cohesive, weak, "--json", d / "ratio.jsonl")
    rows = {r["quantity"]: r for r in json.loads(open(d / "ratio.jsonl").read())["rows"]}
    r = rows["mean abs(Delta y) [R]"]
    q = r["a_value"] / r["b_value"]
    assert r["ratio"] == pytest.approx(q, rel=1e-12)
    assert r["ratio_error"] == pytest.approx(
        q * math.hypot(r["a_error"] / r["a_value"], r["b_error"] / r["b_value"]), rel=1e-12)
    assert f"A/B {q:#.3g}" in r["detail"]  # three digits, trailing zeros kept
    assert "ratio" not in rows["nu(y)"]  # a chi2 row has no value to divide
    assert compare.ratio(1.0, 0.1, 0.0, 0.1) is None  # nothing to divide by
    assert compare.ratio(1.0, 0.1, 0.15, 0.1) is None  # B within two errors of 0
    assert compare.ratio(1.0, 0.1, 0.25, 0.1) is not None
    assert compare.ratio(2.0, 0.2, 4.0, 0.4) == pytest.approx((0.5, 0.5 * math.hypot(0.1, 0.1)))
