"""tools/plot.py: what its figures draw, read back from the matplotlib figures before they are
written (plot.save replaced), on small result files written with h5py or by the program."""

import os
import subprocess
import sys

import h5py
import numpy as np
import pytest
from matplotlib.collections import LineCollection

import loosepack
import test_claims
from script_module import load_script

TOOL = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools", "plot.py")
plot = load_script(TOOL)


@pytest.fixture
def figures(monkeypatch):
    """The figures the plotting functions draw, by file name, kept open instead of written."""
    drawn = {}
    monkeypatch.setattr(plot, "save", lambda fig, out, name, written: drawn.update({name: fig}))
    return drawn


def point(f, k, protocol="C", height=16.0, **attrs):
    """Point k of a result file, with the attributes its label needs and `attrs`."""
    g = f.create_group(f"points/{k:04d}")
    g.attrs.update(protocol=protocol, bond_number=30.0, capture_radius=1.0, height=height,
                   **attrs)
    return g


def collapse_increase_axis(path, figures, mean, sem):
    """The log-axis panel of collapse_increase for protocol-C points of these dnu/nu_i and errors
    (heights 16, 32, ... R; nu_i 0.30, 0.35, ...)."""
    with h5py.File(path, "w") as f:
        points = [point(f, k, height=16.0 * (k + 1), relative_increase_mean=m,
                        relative_increase_sem=s, nu_initial_mean=0.3 + 0.05 * k)
                  for k, (m, s) in enumerate(zip(mean, sem))]
        plot.collapse_increase(None, points, os.path.dirname(path), [])
    return figures["collapse_increase.png"].axes[1]


def test_a_time_step_axis_is_its_own_series_and_named(tmp_path, figures):
    """Points at Bo = 0 and 100 with h = 0.01 and 0.005 (a time-step axis): two series of
    nu_lower_half named by their steps, and labels that tell the four points apart; with the
    time step following the Bond number (the default's h(Bo)), one series and no step named."""
    def scan(path, steps):
        f = h5py.File(path, "w")
        points = [point(f, k, protocol="A", width=12.0, time_step=h,
                        nu_lower_half_mean=0.8 - 0.001 * bo - 10 * h, nu_lower_half_sem=0.01)
                  for k, (bo, h) in enumerate(steps)]
        for g, (bo, _) in zip(points, steps):
            g.attrs["bond_number"] = bo
        return f, points

    f, points = scan(tmp_path / "axis.h5", [(0.0, 0.01), (0.0, 0.005), (100.0, 0.01),
                                           (100.0, 0.005)])
    plot.LABEL_KEYS = plot.label_keys(points)
    assert plot.LABEL_KEYS == ("time_step",)
    assert len({plot.label(g) for g in points}) == 4
    plot.nu_lower_half(points, str(tmp_path), [])
    ax = figures["nu_lower_half.png"].axes[0]
    assert sorted(t.get_text() for t in ax.get_legend().get_texts()) == [
        "time_step 0.005", "time_step 0.01"]
    f.close()
    f, points = scan(tmp_path / "follows.h5", [(0.0, 0.01), (100.0, 0.009)])
    plot.LABEL_KEYS = plot.label_keys(points)
    assert plot.LABEL_KEYS == ()
    plot.nu_lower_half(points, str(tmp_path), [])
    assert len(figures["nu_lower_half.png"].axes[0].get_legend().get_texts()) == 1
    f.close()
    plot.LABEL_KEYS = ()


def test_a_bar_to_zero_but_for_round_off_is_cut(tmp_path, figures):
    """Two members of which one did not collapse: the error is the mean, less round-off; its bar
    is cut like one that reaches 0, and the log axis does not stretch over decades for it."""
    mean = [0.02, 0.03, 0.05]
    sem = [0.005, 0.03 * (1 - 1e-12), 0.01]
    ax = collapse_increase_axis(tmp_path / "r.h5", figures, mean, sem)
    cut = [line for line in ax.lines if line.get_marker() == "v"]
    assert len(cut) == 1 and len(cut[0].get_ydata()) == 1
    low, high = ax.get_ylim()
    assert high / low < 100


def test_collapse_increase_on_a_log_axis_cuts_bars_that_reach_zero(tmp_path, figures):
    """dnu/nu_i against nu_i on log axes: a bar down to 0 or below ends at a positive floor under
    every point, marked "v"; a point at or below 0 is left out; the title says both."""
    mean = [0.02, 0.01, 0.05, -0.01]
    sem = [0.005, 0.015, 0.01, 0.02]  # the second reaches -0.005
    ax = collapse_increase_axis(tmp_path / "c.h5", figures, mean, sem)
    bars = [seg for c in ax.collections if isinstance(c, LineCollection)
            for seg in c.get_segments()]
    assert len(bars) == 3
    lows = sorted(min(seg[:, 1]) for seg in bars)
    assert lows[0] > 0
    drawn = np.concatenate([line.get_ydata() for line in ax.lines if line.get_marker() == "o"])
    assert sorted(drawn) == [0.01, 0.02, 0.05]
    cut = [line for line in ax.lines if line.get_marker() == "v"]
    assert [list(line.get_ydata()) for line in cut] == [[lows[0]]]
    assert lows[0] < min(0.01, 0.02 - 0.005, 0.05 - 0.01)
    assert ax.get_title() == ("v: error bar down to 0 or below, cut; "
                              "1 point at dnu/nu_i <= 0 left out")


def test_collapse_increase_draws_a_series_for_each_bond_number(tmp_path, figures):
    """Protocol-C points at two Bond numbers and three heights: two series against H, each
    named by its Bond number and holding its own three points."""
    with h5py.File(tmp_path / "bo.h5", "w") as f:
        points = [point(f, k, height=h, relative_increase_mean=0.01 * (k + 1),
                        relative_increase_sem=0.001, nu_initial_mean=0.3 + 0.01 * k)
                  for k, h in enumerate([10.0, 14.0, 18.0] * 2)]
        for g in points[3:]:
            g.attrs["bond_number"] = 1000.0
        plot.collapse_increase(None, points, str(tmp_path), [])
    ax = figures["collapse_increase.png"].axes[0]
    assert sorted(t.get_text() for t in ax.get_legend().get_texts()) == [
        "bond_number 1000", "bond_number 30"]
    drawn = sorted(list(line.get_xdata()) for line in ax.lines if line.get_marker() == "o")
    assert drawn == [[10.0, 14.0, 18.0]] * 2


def test_scaled_profiles_leave_out_bo_zero(tmp_path, figures):
    """Fig. 7's heights at Bo = 0 and 100 (three each, Bo = 0 a group of its own): the figure
    draws the Bo = 100 points, as the program's fits across heights take them (0 < Bo < inf)."""
    with h5py.File(tmp_path / "h.h5", "w") as f:
        points = []
        for k, (bo, h) in enumerate([(0.0, 8.0), (0.0, 12.0), (0.0, 16.0), (100.0, 8.0),
                                     (100.0, 12.0), (100.0, 16.0)]):
            g = point(f, k, protocol="A", height=h)
            g.attrs["bond_number"] = bo
            a = g.create_group("avalanche_by_ye")
            a["centre"], a["mean"], a["sem"] = [1.0, 2.0], [-0.1, -0.2], [0.01, 0.01]
            points.append(g)
        plot.scaled_avalanche_profiles(None, points, str(tmp_path), [])
    ax = figures["scaled_avalanche_profiles.png"].axes[0]
    assert sorted(t.get_text() for t in ax.get_legend().get_texts()) == [
        f"A, Bo=100, H={h}" for h in (12, 16, 8)]


def test_histogram_fits_are_drawn_over_the_bins_they_fit(tmp_path, figures):
    """The |Delta y| histogram's fits go through the bins between the counts' 0.5 % and 99.5 %
    quantiles (src/analysis.cpp, histogram_shape): each curve runs from the first such bin's
    centre to the last's."""
    edges = np.arange(11) * 0.5
    # 687 disks: bin 0 holds the first 1 (below 3.4), bin 7 the 683.6th: fitted bins 1 to 7
    counts = np.array([1, 300, 200, 100, 50, 20, 10, 5, 1, 0])
    with h5py.File(tmp_path / "h.h5", "w") as f:
        g = point(f, 0, protocol="A")
        h = g.create_group("abs_dy_histogram")
        h["edges"], h["counts_cut"] = edges, counts
        shape = h.create_group("shape_cut")
        shape.attrs["preferred"] = "exponential"
        for model, coef in (("exponential", [4.0, -0.8]), ("gaussian", [4.0, -0.5, -0.05])):
            fit = shape.create_group(model)
            fit.attrs["valid"] = 1.0
            fit["coef"], fit["error"] = coef, np.full(len(coef), 0.1)
        plot.abs_dy_histograms([g], str(tmp_path), [])
    ax = figures["abs_dy_histograms.png"].axes[0]
    curves = [line for line in ax.lines if line.get_linestyle() in ("-", "--")]
    assert len(curves) == 2
    for line in curves:
        assert (line.get_xdata().min(), line.get_xdata().max()) == (0.75, 3.75)


def test_the_histogram_of_a_cohesive_point_is_drawn_with_its_slices_summed(tmp_path, figures):
    """At 0 < Bo < inf the cut histogram is drawn with its height slices' Gaussians summed
    (claims.SliceMixture; dotted), as fractions of the disks: made of the same disks, the sum's
    mean |Delta y| is the histogram's within the bins' width."""
    arch = lambda y: -12.0 * np.sin(np.pi * y / test_claims.H)
    test_claims.sliced_histogram_file(tmp_path, "arch", arch,
                                      lambda rng, n: rng.normal(0.0, 2.5, n))
    with h5py.File(tmp_path / "arch.h5", "r+") as f:
        g = f["points/0000"]
        g.attrs["capture_radius"] = 1.0
        h = g["abs_dy_histogram"]
        h["counts_cut"] = h["member_counts_cut"][()].sum(axis=0)
        plot.abs_dy_histograms([g], str(tmp_path), [])
        counts, edges = h["counts_cut"][()], h["edges"][()]
    ax = figures["abs_dy_histograms.png"].axes[0]
    dotted, = [line for line in ax.lines if line.get_linestyle() == ":"]
    x, y = dotted.get_xdata(), dotted.get_ydata()
    assert y.sum() == pytest.approx(1.0)
    centres = 0.5 * (edges[1:] + edges[:-1])
    assert abs((x * y).sum() - (centres * counts).sum() / counts.sum()) < 0.5
    with h5py.File(tmp_path / "arch.h5", "r+") as f:  # none at Bo = 0
        f["points/0000"].attrs["bond_number"] = 0.0
        assert plot.slices_sum(f["points/0000"]) is None


def test_a_failed_members_snapshot_is_not_drawn_as_a_deposit(tmp_path, monkeypatch):
    """With --snapshots a failed member (LOOSEPACK_INJECT_NAN=1: member 1) gets no snapshot_1,
    only failure_1; a file written before 2026-12-02 holds a snapshot_1 too (the same state,
    copied in here). plot.py draws the state at the failure (failure_1), and only the finished
    member's snapshot as a deposit."""
    monkeypatch.setenv("LOOSEPACK_INJECT_NAN", "1")
    scan = {"scan": {"seeds": 2}, "system": {"width": 12.0, "height": 12.0, "bond_number": 30}}
    res = loosepack.run(scan, tmp_path / "fail.h5", progress=False, args=["--snapshots"])
    with h5py.File(res.path, "r+") as f:
        members = f["points/0000/members"]
        assert {"snapshot_0", "failure_1"} <= set(members) and "snapshot_1" not in members
        assert list(members["failure"][()]) == [0, 1]
        members.copy("failure_1", "snapshot_1")
    done = subprocess.run([sys.executable, TOOL, res.path, "-o", str(tmp_path / "fig")],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    structures = sorted(p for p in os.listdir(tmp_path / "fig") if p.startswith("structure_"))
    assert structures == ["structure_0000_failure_1.png", "structure_0000_snapshot_0.png"]
