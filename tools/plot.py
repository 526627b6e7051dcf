#!/usr/bin/env python3
"""Figures from a loosepack result file: density profiles, nu_lower_half against Bo, avalanche
profiles, |Delta y| histograms.

    python3 tools/plot.py out/default.h5 [-o figures/]

Uses Debian's python3-h5py and python3-matplotlib (scripts/install-deps.sh installs them).
"""
import argparse
import math
import os
import sys

try:
    import h5py
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError as e:  # pragma: no cover
    sys.exit(f"plot.py: {e}; install python3-h5py and python3-matplotlib (scripts/install-deps.sh)")


def need(group, name, path):
    if name not in group:
        sys.exit(f"plot.py: {path}: dataset '{group.name}/{name}' is missing "
                 "(was the file written by an older loosepack?)")
    return group[name][()]


def label(g):
    a = g.attrs
    bo = a["bond_number"]
    bo_s = "inf" if math.isinf(bo) else f"{bo:g}"
    s = f"{a['protocol'].decode() if isinstance(a['protocol'], bytes) else a['protocol']}, Bo={bo_s}"
    if a["capture_radius"] != 1.0:
        s += f", r_capt={a['capture_radius']:g}"
    return s


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("file")
    ap.add_argument("-o", "--outdir", default=None, help="folder for the PNGs (default: beside the file)")
    args = ap.parse_args()
    if not os.path.exists(args.file):
        sys.exit(f"plot.py: {args.file}: no such file")
    out = args.outdir or os.path.splitext(args.file)[0] + "_figures"
    os.makedirs(out, exist_ok=True)
    try:
        f = h5py.File(args.file, "r")
    except OSError as e:
        sys.exit(f"plot.py: {args.file}: cannot read as HDF5 ({e})")
    with f:
        if "points" not in f:
            sys.exit(f"plot.py: {args.file}: no 'points' group: not a loosepack result file")
        points = [f["points"][k] for k in sorted(f["points"])]
        written = []

        fig, ax = plt.subplots(figsize=(6, 4.5))
        for g in points:
            nu = g["nu"] if "nu" in g else sys.exit(f"plot.py: {g.name}/nu missing")
            ax.errorbar(need(nu, "centre", args.file), need(nu, "mean", args.file),
                        yerr=need(nu, "sem", args.file), label=label(g), capsize=2)
        ax.set_xlabel("y [R]")
        ax.set_ylabel("volume fraction nu")
        ax.legend(fontsize=8)
        fig.tight_layout()
        written.append(os.path.join(out, "density_profiles.png"))
        fig.savefig(written[-1], dpi=120)
        plt.close(fig)

        if len(points) > 1:
            fig, ax = plt.subplots(figsize=(6, 4.5))
            xs, ys, es = [], [], []
            for g in points:
                bo = g.attrs["bond_number"]
                xs.append(bo)
                ys.append(g.attrs["nu_lower_half_mean"])
                es.append(g.attrs["nu_lower_half_sem"])
            # Bo = 0 and inf drawn at the ends of the finite range
            finite_bo = [b for b in xs if b > 0 and not math.isinf(b)]
            lo = min(finite_bo) / 10 if finite_bo else 0.1
            hi = max(finite_bo) * 10 if finite_bo else 10
            pos = [lo if b == 0 else hi if math.isinf(b) else b for b in xs]
            ax.errorbar(pos, ys, yerr=es, fmt="o", capsize=3)
            ax.set_xscale("log")
            ax.set_xlabel("Bond number (Bo = 0 at the left end, inf at the right)")
            ax.set_ylabel("nu_lower_half")
            fig.tight_layout()
            written.append(os.path.join(out, "nu_lower_half.png"))
            fig.savefig(written[-1], dpi=120)
            plt.close(fig)

        fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
        for ax, key, xl in ((axes[0], "avalanche_by_yi", "y_i [R]"), (axes[1], "avalanche_by_ye", "y_e [R]")):
            for g in points:
                a = g[key] if key in g else sys.exit(f"plot.py: {g.name}/{key} missing")
                ax.errorbar(need(a, "centre", args.file), need(a, "mean", args.file),
                            yerr=need(a, "sem", args.file), label=label(g), capsize=2)
            ax.set_xlabel(xl)
        axes[0].set_ylabel("Delta y = y_e - y_i [R]")
        axes[1].legend(fontsize=8)
        fig.tight_layout()
        written.append(os.path.join(out, "avalanche_profiles.png"))
        fig.savefig(written[-1], dpi=120)
        plt.close(fig)

        fig, ax = plt.subplots(figsize=(6, 4.5))
        for g in points:
            h = g["abs_dy_histogram"]
            edges = need(h, "edges", args.file)
            counts = need(h, "counts_cut", args.file)
            if counts.sum() == 0:
                continue
            centres = 0.5 * (edges[1:] + edges[:-1])
            ax.semilogy(centres, counts / counts.sum(), "o-", ms=3, label=label(g))
        ax.set_xlabel("|Delta y| [R] (bottom and top cut)")
        ax.set_ylabel("fraction of disks")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
        else:
            ax.set_title("no disks left after the cuts (observables.cut_bottom, cut_top)", fontsize=9)
        fig.tight_layout()
        written.append(os.path.join(out, "abs_dy_histograms.png"))
        fig.savefig(written[-1], dpi=120)
        plt.close(fig)
    for w in written:
        print(w)


if __name__ == "__main__":
    main()
