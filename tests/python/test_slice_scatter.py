"""bench/slice_scatter.py: the moments of a known sample are the formulas', the residuals are
standardised by each bin's spread within members, and on snapshots made by hand a normal scatter
about the profile is found normal where a two-sided exponential (Laplace: skewness 0, excess
kurtosis 3) or a skewed scatter is not."""

import json
import os

import h5py
import numpy as np
import pytest

from script_module import load_script

HERE = os.path.dirname(os.path.abspath(__file__))
scatter = load_script(os.path.join(HERE, "..", "..", "bench", "slice_scatter.py"))

H, BIN, CUT, MEMBERS, DISKS = 120.0, 4.0, 8.0, 12, 1500


def write_point(path, draw, seed=3):
    """A protocol-A point of MEMBERS members whose disks lie uniformly over the box and drop by
    the profile -6 sin(pi y / H) plus draw(rng, n) of their own."""
    rng = np.random.default_rng(seed)
    with h5py.File(path, "w") as f:
        point = f.create_group("points/0000")
        point.attrs.update({"height": H, "cut_bottom": CUT, "cut_top": CUT})
        point["avalanche_by_ye/centre"] = np.arange(BIN / 2, H, BIN)
        point["members/seed_index"] = np.arange(MEMBERS)
        point["members/top"] = np.full(MEMBERS, H - 1.0)
        for k in range(MEMBERS):
            y_e = rng.uniform(0.0, H - 1.0, DISKS)
            s = point.create_group(f"members/snapshot_{k}")
            s["y_e"] = y_e
            s["y_i"] = y_e + 6.0 * np.sin(np.pi * y_e / H) - draw(rng, DISKS)


def measured(tmp_path, draw):
    path = str(tmp_path / "point.h5")
    write_point(path, draw)
    with h5py.File(path, "r") as f:
        return scatter.measure(f["points/0000"], trials=50)


def test_the_statistics_of_a_known_sample_are_the_formulas():
    # +-1 with equal weight: skewness 0, kurtosis 1 (excess -2), none beyond 3
    np.testing.assert_allclose(scatter.statistics(np.array([-1.0, 1.0] * 5)), [0.0, -2.0, 0.0],
                               atol=1e-12)
    # {0, 0, 0, 4}: mean of z^2 = 4, z^3 = 16, z^4 = 64 -> skewness 16 / 8 = 2, kurtosis 64 / 16
    z = np.array([0.0, 0.0, 0.0, 4.0])
    np.testing.assert_allclose(scatter.statistics(z), [2.0, 1.0, 0.25], atol=1e-12)


def test_residuals_are_taken_about_each_group_mean_over_the_bins_spread():
    # one bin, two members of five disks: deviations +-1 (4 of them) and 0, sum of squares 4
    # each, dof 4 each: spread 1, so each residual is its deviation
    groups = [(np.zeros(5, int), np.array([1.0, -1.0, 1.0, -1.0, 0.0]) + 7.0),
              (np.zeros(5, int), np.array([2.0, 0.0, 2.0, 0.0, 1.0]) - 3.0)]
    for z in scatter.residuals(groups):
        np.testing.assert_allclose(z, [1.0, -1.0, 1.0, -1.0, 0.0])
    # a group of fewer than MIN_GROUP disks has no residuals
    assert [r.size for r in scatter.residuals(groups + [(np.zeros(4, int), np.ones(4))])] == \
        [5, 5, 0]


def test_a_normal_scatter_about_the_profile_is_found_normal(tmp_path):
    out = measured(tmp_path, lambda rng, n: 2.5 * rng.standard_normal(n))
    for name in scatter.STATISTICS:
        assert abs(out[name]["t"]) < 4.0, (name, out[name])
    assert out["members"] == MEMBERS
    # disks within the cut: (H - 1 - 2 CUT) / (H - 1) of them, all in groups of MIN_GROUP or more
    assert out["disks"] == pytest.approx(MEMBERS * DISKS * (H - 1 - 2 * CUT) / (H - 1), rel=0.03)


def test_heavy_tails_and_a_tail_of_larger_drops_are_found(tmp_path):
    laplace = measured(tmp_path, lambda rng, n: rng.laplace(0.0, 2.0, n))
    assert laplace["excess_kurtosis"]["value"] == pytest.approx(3.0, abs=0.6)
    assert laplace["excess_kurtosis"]["t"] > 4.0
    assert abs(laplace["skewness"]["t"]) < 4.0
    # larger drops: Delta y less an exponential of mean 2 R (skewness -2 of Delta y)
    drops = measured(tmp_path, lambda rng, n: -rng.exponential(2.0, n))
    assert drops["skewness"]["value"] == pytest.approx(-2.0, abs=0.3)
    assert drops["skewness"]["t"] < -4.0


def test_a_point_without_snapshots_is_refused(tmp_path):
    path = str(tmp_path / "none.h5")
    write_point(path, lambda rng, n: np.zeros(n))
    with h5py.File(path, "a") as f:
        for k in range(1, MEMBERS):
            del f[f"points/0000/members/snapshot_{k}"]
    with h5py.File(path, "r") as f, pytest.raises(SystemExit, match="1 members with snapshots"):
        scatter.measure(f["points/0000"])


def test_the_command_appends_one_record_per_run(tmp_path, capsys):
    path, record = str(tmp_path / "point.h5"), tmp_path / "scatter.jsonl"
    write_point(path, lambda rng, n: 2.5 * rng.standard_normal(n))
    with h5py.File(path, "a") as f:
        f.attrs["git_commit"] = "abc1234"
    for label in ("first", "second"):
        scatter.main([path, "--json", str(record), "--label", label])
    assert f"{MEMBERS} members" in capsys.readouterr().out
    lines = [json.loads(line) for line in record.read_text().splitlines()]
    assert [r["label"] for r in lines] == ["first", "second"]
    for r in lines:
        assert (r["point"], r["height"], r["members"]) == ("0000", H, MEMBERS)
        assert r["run"] == {"git_commit": "abc1234"} and "date" in r["env"]
        assert set(scatter.STATISTICS) <= set(r)
    with pytest.raises(SystemExit, match="no point 0001"):
        scatter.main([path, "--point", "0001"])
