#!/usr/bin/env python3
"""Figures from a loosepack result file (PNG), with the fits the program stored.

    /usr/bin/python3 tools/plot.py out/default.h5 [-o figures/]
    /usr/bin/python3 tools/plot.py out/h400.h5 out/h800.h5 -o figures/   # the points of several files

Several files are drawn as one set of points (each file's own fits on its points, each point's label
naming its file), e.g. the tall runs, one height per file: then the fits across points (c2 and a
against H, dnu/nu_i against H and nu_i) are not drawn, since the program makes them within one file,
nor the pictures of single members (snapshots, trajectories): draw those from each file alone.

Always: density profiles against y and depth, avalanche profiles with their fits, |Delta y|
histograms with the Gaussian and exponential fits (and, for protocol A at 0 < Bo < inf, the sum
of the height slices' Gaussians, tools/claims.py's SliceMixture), deposition density with the
final density predicted from it. When the file has them: nu_lower_half against the Bond number,
or against the capture radius where all points share one Bond number (several points), protocol-A
profiles of several heights scaled by H with c2 and the slice model's a against H (the paper's
fig. 7), dnu/nu_i against H and against nu_i (protocol C points), avalanche-event size
distributions (protocol A), a picture of each finished member's snapshot with its compressive
contact forces (run with --snapshots; the paper's fig. 1), of each failed member's state at its
failure, and the trajectories of every k-th disk (observables.trajectory_every; the paper's
fig. 5).

Uses Debian's python3-h5py and python3-matplotlib (scripts/install-deps.sh installs them).
"""
import argparse
import io
import math
import os
import sys

try:
    import h5py
    import matplotlib
    import numpy as np

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker
    from matplotlib.collections import LineCollection, PatchCollection
    from matplotlib.patches import Circle
except ImportError as e:  # pragma: no cover
    sys.exit(f"plot.py: {e}; install python3-h5py and python3-matplotlib (scripts/install-deps.sh)")

# Input the figures cannot be drawn from: the message and exit status 2, as claims.py and
# compare.py (1 is left for errors while writing).
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from claims import (SHAPE_TAIL, SYSTEM_BUT_BOND, Histogram, SliceMixture,  # noqa: E402
                    attribute_value, check_result_file, shape_band, text, unusable)



def need(group, name):
    """A dataset (or group) that must be there; a clear message and exit otherwise."""
    if name not in group:
        unusable(f"plot.py: {group.file.filename}: '{group.name}/{name}' is missing "
                 "(was the file written by an older loosepack?)")
    obj = group[name]
    return obj[()] if isinstance(obj, h5py.Dataset) else obj


def attr(obj, name):
    """An attribute that must be there; a clear message and exit otherwise."""
    if name not in obj.attrs:
        unusable(f"plot.py: {obj.file.filename}: attribute '{name}' of '{obj.name}' is missing "
                 "(was the file written by an older loosepack?)")
    return obj.attrs[name]


def bars(errors):
    """Standard errors as error bars: one with no estimate (a single member) draws no bar."""
    e = np.asarray(errors, dtype=float)
    return np.where(np.isfinite(e), e, 0.0)


def sem(group):
    """A group's standard errors (dataset `sem`) as error bars."""
    return bars(need(group, "sem"))


SEVERAL_FILES = False  # main(): several files drawn together, each point labelled with its file


def file_tag(g):
    """" [FILE]" where several files are drawn (points of the same parameters in two files would
    look alike), else ""."""
    return f" [{os.path.basename(g.file.filename)}]" if SEVERAL_FILES else ""


# Parameters a label names besides protocol, Bo, r_capt and H: those in which points that
# would be labelled alike differ (main(): splitting_keys), e.g. a time step or width axis.
LABEL_KEYS = ()
LABEL_BASE = ("protocol", "bond_number", "capture_radius", "height")


def splitting_keys(points, base, candidates):
    """The candidate attributes in which some points equal in `base` (and file) differ: what a
    point's name must add so that two such points do not read alike."""
    out = []
    for k in candidates:
        seen = {}
        for g in points:
            if k not in g.attrs:
                continue
            key = tuple(attribute_value(g.attrs[b]) if b in g.attrs else None
                        for b in base) + (file_tag(g),)  # a file of an older program lacks some
            seen.setdefault(key, set()).add(attribute_value(attr(g, k)))
        if any(len(v) > 1 for v in seen.values()):
            out.append(k)
    return tuple(out)


def label_keys(points):
    """LABEL_KEYS of these points: the scan parameters that split points alike in protocol, Bo,
    r_capt and H, and the time step where it splits points alike in every scan parameter (by
    default it follows Bo and d_c)."""
    return (splitting_keys(points, LABEL_BASE, [k for k in SCAN_KEYS if k not in LABEL_BASE])
            + splitting_keys(points, SCAN_KEYS, ("time_step",)))


def label(g):
    bo = attr(g, "bond_number")
    bo_s = "inf" if math.isinf(bo) else f"{bo:g}"
    s = f"{text(attr(g, 'protocol'))}, Bo={bo_s}"
    if attr(g, "capture_radius") != 1.0:
        s += f", r_capt={attr(g, 'capture_radius'):g}"
    s += f", H={attr(g, 'height'):g}"
    s += "".join(f", {k}={attribute_value(attr(g, k)):g}" for k in LABEL_KEYS if k in g.attrs)
    return s + file_tag(g)


def fit_of(group, name):
    """(coef, error) of a stored fit, or None when absent or invalid."""
    if name not in group:
        return None
    f = group[name]
    if f.attrs.get("valid", 0) == 0:
        return None
    return need(f, "coef"), need(f, "error")


def bin_positions(a):
    """Each bin at the mean position of its disks, where the fits put it (older files: the
    bin centres)."""
    return need(a, "position") if "position" in a else need(a, "centre")


def poly(coef, x):
    return sum(c * x ** k for k, c in enumerate(coef))


def save(fig, out, name, written):
    """The figure, drawn in memory: `written` collects (path, PNG bytes) for write_figures, so a
    file that fails at a later figure leaves no figure of it on disk."""
    fig.tight_layout()
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=120)
    plt.close(fig)
    written.append((os.path.join(out, name), png.getvalue()))


def write_figures(out, written):
    """Each figure whole (a temporary file renamed onto its name), once all are drawn."""
    try:
        os.makedirs(out, exist_ok=True)
    except OSError as e:
        sys.exit(f"plot.py: cannot make the folder {out} for the figures ({e})")
    for path, png in written:
        with open(path + ".tmp", "wb") as f:
            f.write(png)
        os.replace(path + ".tmp", path)
        print(path)


def density_profiles(points, out, written):
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
    for g in points:
        nu = need(g, "nu")
        for ax, x in ((axes[0], need(nu, "centre")), (axes[1], need(nu, "depth"))):
            ax.errorbar(x, need(nu, "mean"), yerr=sem(nu), label=label(g), capsize=2)
    axes[0].set_xlabel("y [R]")
    axes[1].set_xlabel("depth H - y [R]")
    axes[0].set_ylabel("volume fraction nu")
    axes[1].legend(fontsize=7)
    save(fig, out, "density_profiles.png", written)


# What tells series apart (claims.SYSTEM_BUT_BOND: not the time step, which the default sets
# from Bo, nor gravity and the density, which set units).
SCAN_KEYS = ("protocol", "bond_number") + SYSTEM_BUT_BOND


def series_along(points, x_key):
    """The points as series along the attribute `x_key`: one for each set of the other scan
    parameters (and file, where several are drawn), each with its name, which holds the
    parameters that differ between series ("" where none does), in the order of the keys."""
    others = [k for k in SCAN_KEYS if k != x_key and k in points[0].attrs]
    # The default time step follows Bo and d_c: a series of its own only where points of one x
    # and one set of the others differ in it (a time step axis).
    others += splitting_keys(points, [x_key] + others, ("time_step",))
    varying = [k for k in others if len({attribute_value(attr(g, k)) for g in points}) > 1]
    series = {}
    for g in points:
        key = tuple(attribute_value(attr(g, k)) for k in others) + (file_tag(g),)
        series.setdefault(key, []).append(g)
    named = []
    for key, gs in sorted(series.items()):
        values = dict(zip(others, key))
        name = ", ".join(f"{k} {values[k]:g}" if isinstance(values[k], float) else f"{values[k]}"
                         for k in varying) + key[-1]
        named.append((name.strip(), sorted(gs, key=lambda g: float(attr(g, x_key)))))
    return named


def nu_lower_half(points, out, written):
    """nu_lower_half against the Bond number, or against the capture radius where all points
    share one Bond number (figs. 2-3, 13): a series for each set of the other scan parameters,
    named by those that differ between series, each point at its own tick (Bo = 0 and inf at the
    ends of the log axis, named so)."""
    if len(points) < 2:
        return
    x_key = next((k for k in ("bond_number", "capture_radius")
                  if len({float(attr(g, k)) for g in points}) > 1), None)
    if x_key is None:
        return
    xs = sorted({float(attr(g, x_key)) for g in points})
    finite = [b for b in xs if b > 0 and not math.isinf(b)]
    lo = min(finite) / 10 if finite else 0.1
    hi = max(finite) * 10 if finite else 10
    where = lambda b: lo if b == 0 else hi if math.isinf(b) else b
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for name, gs in series_along(points, x_key):
        ax.errorbar([where(float(attr(g, x_key))) for g in gs],
                    [attr(g, "nu_lower_half_mean") for g in gs],
                    yerr=bars([attr(g, "nu_lower_half_sem") for g in gs]), fmt="o-", capsize=3,
                    label=name or f"{text(attr(gs[0], 'protocol'))}, {attr(gs[0], 'width'):g} R "
                                  f"x {attr(gs[0], 'height'):g} R")
    ax.set_xscale("log")
    ax.set_xticks([where(b) for b in xs],
                  ["0" if b == 0 else "inf" if math.isinf(b) else f"{b:g}" for b in xs])
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_xlabel("Bond number" if x_key == "bond_number" else "capture radius r_capt [R]")
    ax.set_ylabel("nu_lower_half")
    ax.legend(fontsize=7)
    save(fig, out, "nu_lower_half.png", written)


def avalanche_profiles(points, out, written):
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
    for ax, key, xl in ((axes[0], "avalanche_by_yi", "y_i [R]"),
                        (axes[1], "avalanche_by_ye", "y_e [R]")):
        for g in points:
            a = need(g, key)
            line = ax.errorbar(bin_positions(a), need(a, "mean"), yerr=sem(a),
                               fmt="o", ms=3, label=label(g), capsize=2)
            f = fit_of(a, "fit")
            if f is not None:
                x = np.linspace(0, attr(g, "height"), 200)
                ax.plot(x, poly(f[0], x), "-", color=line[0].get_color(), lw=1)
            s = fit_of(a, "slice_parabola")
            if s is not None:
                H = attr(g, "height")
                x = np.linspace(0, H, 200)
                ax.plot(x, -s[0][0] * x * (1 - x / H), ":", color=line[0].get_color(), lw=1)
        ax.set_xlabel(xl)
    axes[0].set_ylabel("Delta y = y_e - y_i [R]")
    fig.suptitle("points: ensemble mean +- standard error; lines: fits; dotted: slice model",
                 fontsize=9)
    axes[1].legend(fontsize=7)
    save(fig, out, "avalanche_profiles.png", written)


def fitted_range(edges, counts):
    """(first, last) centre of the bins a histogram shape was fitted to (claims.shape_band, the
    program's band): a fit is drawn there only."""
    centres = 0.5 * (edges[1:] + edges[:-1])[shape_band(counts)]
    return centres.min(), centres.max()


def slices_sum(g):
    """The cut |Delta y| histogram of a protocol-A point with 0 < Bo < inf as its height slices'
    Gaussians summed (claims.SliceMixture), as fractions of its disks per bin; None where the
    file lacks the per-member rows it is made of, or has fewer than 2 members."""
    a = g.attrs
    if (text(a["protocol"]) != "A" or not 0 < float(a["bond_number"]) < math.inf or
            SliceMixture.missing(g) is not None):
        return None
    hist = Histogram(g["abs_dy_histogram"], g.file.filename)
    if hist.members < 2:
        return None
    total = SliceMixture(g, hist).total
    return total / total.sum() if total.sum() > 0 else None


def abs_dy_histograms(points, out, written):
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for g in points:
        h = need(g, "abs_dy_histogram")
        edges = need(h, "edges")
        counts = need(h, "counts_cut")
        if counts.sum() == 0:
            continue
        centres = 0.5 * (edges[1:] + edges[:-1])
        norm = counts.sum()
        line = ax.semilogy(centres, counts / norm, "o", ms=3, label=label(g))[0]
        if "shape_cut" in h:
            shape = h["shape_cut"]
            pref = text(attr(shape, "preferred"))
            for model, style in (("gaussian", "-"), ("exponential", "--")):
                f = fit_of(shape, model)
                if f is None:
                    continue
                x = np.linspace(*fitted_range(edges, counts), 200)
                lw = 1.5 if model == pref else 0.7
                ax.semilogy(x, np.exp(poly(f[0], x)) / norm, style, color=line.get_color(), lw=lw)
        summed = slices_sum(g)
        if summed is not None:
            ax.semilogy(centres, summed, ":", color=line.get_color(), lw=1.2)
    ax.set_xlabel("|Delta y| [R] (bottom and top cut)")
    ax.set_ylabel("fraction of disks")
    ax.set_title("solid: Gaussian fit, dashed: exponential, bold: preferred, over the bins\nthey "
                 f"fit (the middle {100 * (1 - 2 * SHAPE_TAIL):g} % of the disks); dotted: the "
                 "height slices' Gaussians summed", fontsize=9)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7)
        ax.set_ylim(bottom=1e-5)
    else:
        ax.set_title("no disks left after the cuts (observables.cut_bottom, cut_top)", fontsize=9)
    save(fig, out, "abs_dy_histograms.png", written)


def deposition_density(points, out, written):
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for g in points:
        nu, nud = need(g, "nu"), need(g, "nu_deposition")
        line = ax.plot(need(nud, "centre"), need(nud, "mean"), ":", label=f"nu_d(y_i), {label(g)}")[0]
        ax.errorbar(need(nu, "centre"), need(nu, "mean"), yerr=sem(nu), fmt="o", ms=3,
                    color=line.get_color(), capsize=2)
        if "predicted" in nu:
            ax.plot(need(nu, "centre"), need(nu, "predicted"), "-", color=line.get_color(), lw=1.5)
    ax.set_xlabel("y [R]")
    ax.set_ylabel("volume fraction")
    ax.set_title("dotted: nu_d(y_i); points: nu(y); line: nu predicted from nu_d", fontsize=9)
    ax.legend(fontsize=6)
    save(fig, out, "deposition_density.png", written)


# The parameters that must agree for profiles of different heights to be compared.
SAME_BUT_HEIGHT = ("bond_number", "capture_radius", "cohesion_range", "friction",
                   "rolling_friction", "polydispersity", "width", "floor_cohesion", "time_step",
                   "radius", "disk_density", "gravity")  # as the program's fits across points


def scaled_avalanche_profiles(f, points, out, written):
    """The paper's fig. 7: protocol-A profiles of several heights with both axes over H (a
    profile H f(y/H) collapses), beside the curvature c2 and the slice model's a against H.
    Drawn for the largest group of protocol-A points that differ only in their height, at a
    Bond number between 0 and inf (as the program's fits across heights take them)."""
    groups = {}
    for g in points:
        if text(attr(g, "protocol")) == "A" and 0 < attr(g, "bond_number") < math.inf:
            key = tuple(float(g.attrs[k]) for k in SAME_BUT_HEIGHT if k in g.attrs)
            groups.setdefault(key, []).append(g)
    a_pts = max(groups.values(), key=lambda v: len({attr(g, "height") for g in v}), default=[])
    if len({attr(g, "height") for g in a_pts}) < 2:
        return
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    c2, sa = [], []  # (H, value, error) of the curvature and of the slice model's a
    for g in a_pts:
        a = need(g, "avalanche_by_ye")
        h = attr(g, "height")
        line = axes[0].errorbar(np.asarray(bin_positions(a)) / h, np.asarray(need(a, "mean")) / h,
                                yerr=np.asarray(sem(a)) / h, fmt="o", ms=3, capsize=2,
                                label=label(g))
        s = fit_of(a, "slice_parabola")
        if s is not None:
            u = np.linspace(0, 1, 200)
            axes[0].plot(u, -s[0][0] * u * (1 - u), ":", color=line[0].get_color(), lw=1)
            if s[0][0] > 0:
                sa.append((h, s[0][0], s[1][0]))
        fit = fit_of(a, "fit")
        if fit is not None and len(fit[0]) > 2 and fit[0][2] > 0:
            c2.append((h, fit[0][2], fit[1][2]))
    axes[0].set_xlabel("y_e / H")
    axes[0].set_ylabel("Delta y / H")
    axes[0].set_title("scaled by H (dotted: slice model)", fontsize=9)
    axes[0].legend(fontsize=7)
    for pts, fmt, name in ((c2, "o", "c2 of Delta y(y_e)"), (sa, "s", "slice model a")):
        if pts:
            axes[1].errorbar(*zip(*[(h, v) for h, v, _ in pts]), yerr=bars([e for _, _, e in pts]),
                             fmt=fmt, capsize=3, label=name)
    an = f["analysis"] if f is not None and "analysis" in f else None
    for key, name in (("quadratic_vs_height", "c2"), ("slice_vs_height", "a")):
        fit = fit_of(an, key) if an is not None else None
        if fit is not None:
            fitted = [attr(g, "height") for g in fitted_points(an, key, points)]
            hs = np.linspace(min(fitted), max(fitted))
            axes[1].plot(hs, np.exp(fit[0][0]) * hs ** fit[0][1], "-", lw=1,
                         label=f"{name} ~ H^({fit[0][1]:.2f} +- {fit[1][1]:.2f})")
    axes[1].set_xscale("log")
    axes[1].set_yscale("log")
    heights = sorted({attr(g, "height") for g in a_pts})
    axes[1].set_xticks(heights, [f"{h:g}" for h in heights])
    axes[1].xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    axes[1].set_xlabel("H [R]")
    axes[1].set_title("paper: c2 ~ 1/H, a fixed", fontsize=9)
    axes[1].legend(fontsize=7)
    save(fig, out, "scaled_avalanche_profiles.png", written)


def fitted_points(an, name, points):
    """The points a fit across points went through (`analysis/NAME/scan_points`)."""
    fit = need(an, name)
    if "scan_points" not in fit:
        path = fit.file.filename
        unusable(f"plot.py: {path}: '{fit.name}/scan_points' is missing: a file of an older "
                 f"loosepack; `loosepack analyse {path}` adds it")
    held = {int(g.name.rsplit("/", 1)[1]): g for g in points if g.file == fit.file}
    return [held[int(k)] for k in fit["scan_points"][()] if int(k) in held]


# An error bar whose lower end lies below this fraction of its value reaches zero but for
# round-off (two members, one of which did not collapse: the error equals the mean).
RELATIVE_ZERO = 1e-3


def collapse_increase(f, points, out, written):
    """dnu/nu_i of the protocol-C points against H and, on log axes, against nu_i. There an error
    bar that reaches 0 or below is cut at a floor under every other point and ends in a "v"; a
    point at 0 or below is left out; the panel's title says so where it happens."""
    c = [g for g in points if text(attr(g, "protocol")) == "C"]
    if len(c) < 2:
        return
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    increase = np.array([attr(g, "relative_increase_mean") for g in c], dtype=float)
    lower = increase - bars([attr(g, "relative_increase_sem") for g in c])
    lower[lower <= RELATIVE_ZERO * increase] = 0.0  # a bar to 0 but for round-off reaches 0
    floor = 0.5 * min(np.concatenate([increase[increase > 0], lower[lower > 0]]), default=1.0)
    for name, g_rc in series_along(c, "height"):  # a series for each set of the others
        inc = np.array([attr(g, "relative_increase_mean") for g in g_rc], dtype=float)
        err = bars([attr(g, "relative_increase_sem") for g in g_rc])
        nu_i = np.array([attr(g, "nu_initial_mean") for g in g_rc], dtype=float)
        lab = name or f"r_capt = {attr(g_rc[0], 'capture_radius'):g}"
        axes[0].errorbar([attr(g, "height") for g in g_rc], inc, yerr=err, fmt="o", capsize=3,
                         label=lab)
        on = inc > 0  # a log axis has no place for the others
        cut = on & (inc - err <= RELATIVE_ZERO * inc)
        down = np.where(cut, inc - floor, err)
        line = axes[1].errorbar(nu_i[on], inc[on], yerr=[down[on], err[on]], fmt="o", capsize=3,
                                label=lab)
        axes[1].plot(nu_i[cut], np.full(cut.sum(), floor), "v", color=line[0].get_color())
    notes = []
    if ((increase > 0) & (lower <= 0)).any():
        notes.append("v: error bar down to 0 or below, cut")
    left_out = int((increase <= 0).sum())
    if left_out:
        notes.append(f"{left_out} point{'s' if left_out > 1 else ''} at dnu/nu_i <= 0 left out")
    axes[1].set_title("; ".join(notes), fontsize=9)
    axes[0].set_xscale("log")
    axes[0].set_xlabel("H [R]")
    axes[1].set_xscale("log")
    axes[1].set_yscale("log")
    axes[1].set_xlabel("nu_i")
    # Plain numbers on the log axes: at 1..9 of each decade where an axis spans less than two
    # decades (as the collapse's usually do), else at the decades alone.
    for axis, limits in ((axes[0].xaxis, axes[0].get_xlim()), (axes[1].xaxis, axes[1].get_xlim()),
                         (axes[1].yaxis, axes[1].get_ylim())):
        narrow = limits[0] > 0 and limits[1] / limits[0] < 100
        axis.set_major_locator(matplotlib.ticker.LogLocator(subs=range(1, 10) if narrow else (1,)))
        axis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        axis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    for ax in axes:
        ax.set_ylabel("dnu / nu_i")
        ax.legend(fontsize=8)
    an = f["analysis"] if f is not None and "analysis" in f else None
    if an is not None:
        fh = fit_of(an, "increase_vs_log_height")
        if fh is not None:
            H = [attr(g, "height") for g in fitted_points(an, "increase_vs_log_height", points)]
            x = np.linspace(min(H), max(H), 100)
            axes[0].plot(x, fh[0][0] + fh[0][1] * np.log(x), "-",
                         label=f"{fh[0][0]:.3f} + {fh[0][1]:.3f} ln H")
            axes[0].legend(fontsize=8)
        fn = fit_of(an, "increase_vs_nu_initial")
        if fn is not None:
            ni = [attr(g, "nu_initial_mean")
                  for g in fitted_points(an, "increase_vs_nu_initial", points)]
            x = np.linspace(min(ni), max(ni), 100)
            axes[1].plot(x, np.exp(fn[0][0]) * x ** fn[0][1], "-",
                         label=f"{math.exp(fn[0][0]):.3f} nu_i^{fn[0][1]:.2f}")
            axes[1].legend(fontsize=8)
    save(fig, out, "collapse_increase.png", written)


def event_sizes(points, out, written):
    a = [g for g in points if "events" in g]
    if not a:
        return
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5))
    for g in a:
        e = g["events"]
        edges = need(e, "edges")
        centres = np.sqrt(edges[1:] * edges[:-1])
        widths = edges[1:] - edges[:-1]
        for ax, key in ((axes[0], "moved_counts"), (axes[1], "downward_counts"),
                        (axes[2], "steps_counts")):
            if key not in e:  # files of earlier versions
                continue
            c = need(e, key)
            total = c.sum()
            if total == 0:
                continue
            keep = c > 0
            ax.loglog(centres[keep], (c / total / widths)[keep], "o-", ms=3, label=label(g))
    axes[0].set_xlabel("disks moved in one event")
    axes[1].set_xlabel("summed downward displacement of one event [R]")
    axes[2].set_xlabel("steps to rest of one event")
    for ax in axes:
        ax.set_ylabel("probability density")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    save(fig, out, "event_sizes.png", written)


def member_groups(points, prefix):
    """(point group, member subgroup name, subgroup) for every members/<prefix>K of every point."""
    for g in points:
        m = need(g, "members")
        for name in sorted(k for k in m if k.startswith(prefix)):
            yield g, name, m[name]


def snapshots(points, out, written):
    """The paper's fig. 1: disks and compressive contact forces as lines of width ~ force, of
    every finished member; and the state of every failed member at its failure (velocities as
    arrows; disks with a non-finite state are named in the title). A failed member's snapshot_K
    (in files written before 2026-12-02, the same state as its failure_K) is no deposit and is not
    drawn: its failure_K is."""
    for prefix in ("snapshot_", "failure_"):
        for g, name, s in member_groups(points, prefix):
            if prefix == "snapshot_" and member_failed(g, int(name[len(prefix):])):
                continue
            structure(g, name, s, out, written)


def member_failed(g, seed):
    """Whether the member of seed index `seed` of point `g` failed (members/failure not 0)."""
    m = need(g, "members")
    return bool((need(m, "failure")[need(m, "seed_index") == seed] != 0).any())


def structure(g, name, s, out, written):
    x, y, r = need(s, "x"), need(s, "y_e"), need(s, "radius")
    W = attr(g, "width")
    failed = "failure" in s.attrs
    finite = np.isfinite(x) & np.isfinite(y)
    if failed:
        vx, vy = need(s, "vx"), need(s, "vy")
        finite &= np.isfinite(vx) & np.isfinite(vy)
    top = max(y[finite].max() + 2 if finite.any() else 1.0, 1.0)
    # A failed member's solution may have blown up: the box is drawn, and the disks that left it
    # are counted in the title instead of stretching the picture to where they went.
    box_top = attr(g, "height") + 4.0 * float(r[np.isfinite(r)].max() if np.isfinite(r).any() else 1.0)
    outside = finite & ((y > box_top) | (y < 0.0))
    if failed:
        top = min(top, box_top)
    fig, ax = plt.subplots(figsize=(6, max(2.0, 6 * min(3.0, top / W))))  # room for the title
    ax.add_collection(PatchCollection([Circle((a, b), c) for a, b, c in
                                       zip(x[finite], y[finite], r[finite])],
                                      facecolor="0.85", edgecolor="0.5", lw=0.2))
    ci, cj, fn = need(s, "contact_i"), need(s, "contact_j"), need(s, "contact_normal")
    segs, widths = [], []
    good = fn[np.isfinite(fn)]
    fmax = good.max() if len(good) and good.max() > 0 else 1.0
    for i, j, f in zip(ci.astype(int), cj.astype(int), fn):
        if not f > 0 or j < 0 or not (finite[i] and finite[j]) or outside[i] or outside[j]:
            continue
        dx = x[j] - x[i]
        dx -= W * round(dx / W)  # minimum image across the periodic boundary
        segs.append([(x[i], y[i]), (x[i] + dx, y[j])])
        widths.append(3.0 * f / fmax)
    ax.add_collection(LineCollection(segs, linewidths=widths, colors="tab:red"))
    title = f"{label(g)}, {name}: compressive forces (width ~ force)"
    if failed:
        ax.quiver(x[finite], y[finite], vx[finite], vy[finite], color="tab:blue", width=0.003)
        bad = np.where(~finite)[0]  # their place is lost: named in the title
        why = attr(s, "failure")
        why = why.decode() if isinstance(why, bytes) else str(why)
        title = f"{label(g)}, {name} (member {int(attr(s, 'member'))}): {why}"
        if len(bad):
            title += f"; disks with a non-finite state: {list(bad)[:10]}"
        if outside.any():
            title += (f"; {int(outside.sum())} disks outside the box (y from "
                      f"{y[outside].min():.3g} to {y[outside].max():.3g} R)")
    ax.set_xlim(0, W)
    ax.set_ylim(0, top)
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=7, wrap=True)
    save(fig, out, f"structure_{g.name.split('/')[-1]}_{name}.png", written)


def trajectories(points, out, written):
    for g, name, t in member_groups(points, "trajectory_"):
        disk, x, y = need(t, "disk"), need(t, "x"), need(t, "y")
        if len(disk) == 0:
            continue
        W = attr(g, "width")
        fig, ax = plt.subplots(figsize=(6, 6))
        for d in np.unique(disk):
            sel = disk == d
            xs, ys = x[sel].astype(float), y[sel].astype(float)
            # Break the line where it wraps around the periodic boundary.
            jump = np.abs(np.diff(xs)) > 0.5 * W
            xs = np.insert(xs, np.where(jump)[0] + 1, np.nan)
            ys = np.insert(ys, np.where(jump)[0] + 1, np.nan)
            ax.plot(xs, ys, "-", lw=0.5)
        ax.set_xlim(0, W)
        ax.set_xlabel("x [R]")
        ax.set_ylabel("y [R]")
        ax.set_title(f"{label(g)}, {name}: trajectories", fontsize=8)
        save(fig, out, f"trajectories_{g.name.split('/')[-1]}_{name}.png", written)


def open_result(path):
    """A result file, open for reading; a clear message and exit if it is not one."""
    if not os.path.exists(path):
        unusable(f"plot.py: {path}: no such file")
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        unusable(f"plot.py: {path}: cannot read as HDF5 ({e})")
    check_result_file(f, path, "plot.py")
    if not len(f["points"]):
        unusable(f"plot.py: {path}: no scan point in 'points': nothing to draw")
    return f


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("file", nargs="+")
    ap.add_argument("-o", "--outdir", default=None,
                    help="folder for the PNGs (default: beside the first file)")
    args = ap.parse_args()
    out = args.outdir or os.path.splitext(args.file[0])[0] + "_figures"
    files = [open_result(path) for path in args.file]
    # One file: its fits across points too. Several: those fits belong to each file alone.
    whole = files[0] if len(files) == 1 else None
    global SEVERAL_FILES, LABEL_KEYS
    SEVERAL_FILES = len(files) > 1
    points = [f["points"][k] for f in files for k in sorted(f["points"])]
    LABEL_KEYS = label_keys(points)
    written = []
    density_profiles(points, out, written)
    nu_lower_half(points, out, written)
    avalanche_profiles(points, out, written)
    abs_dy_histograms(points, out, written)
    deposition_density(points, out, written)
    scaled_avalanche_profiles(whole, points, out, written)
    collapse_increase(whole, points, out, written)
    event_sizes(points, out, written)
    if whole is not None:  # their file names hold the point's index within its file
        snapshots(points, out, written)
        trajectories(points, out, written)
    for f in files:
        f.close()
    write_figures(out, written)


if __name__ == "__main__":
    main()
