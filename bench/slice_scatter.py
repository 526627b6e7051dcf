#!/usr/bin/env python3
"""The shape of the disks' scatter about the avalanche profile within each height slice: is it
the normal that the sum of the slices' Gaussians (tools/claims.py, SliceMixture) takes it for?

    /usr/bin/python3 bench/slice_scatter.py OUT.h5 [--point NAME] [--json FILE --label LABEL]

reads the snapshots of a protocol-A point written with `loosepack run --snapshots` (each disk's
y_i and y_e). In each member, the disks within the cut (y_e from `cut_bottom` to the member's top
less `cut_top`) are grouped by the bins of Delta y(y_e) (`avalanche_by_ye`); a disk's residual is
its Delta y less its group's mean, over its bin's spread within members (pooled over the members'
groups). Of these standardised residuals it prints the skewness (negative: a longer tail of
larger drops), the excess kurtosis (0 for a normal; positive: heavier tails) and the share beyond
3 (0.27 % for a normal), each with its jackknife error over members (the disks of one avalanche
move together, the members are independent), and what the same statistic gives on NULL normal
ensembles of the same groups (a group's own mean taken out biases it a little, by the group's
size). t is the statistic less the normal ensembles' mean, over its jackknife error.
docs/REPRODUCTION.md ("Why the Gaussian gives way in taller boxes") uses it for what the slices'
sum leaves out.
"""
import argparse
import datetime
import json
import os
import platform
import sys

import h5py
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
import claims  # noqa: E402

MIN_GROUP = 5  # disks of a member's bin for its mean to be taken out
NULL = 200  # normal ensembles for the bias of each statistic
STATISTICS = ("skewness", "excess_kurtosis", "beyond_3")


def slice_groups(point):
    """Per member with a snapshot: the bin of each disk within the cut, and its Delta y."""
    prof = point["avalanche_by_ye"]
    centre = prof["centre"][()]
    width = centre[1] - centre[0]
    bottom, top_cut = claims.cuts(point)
    members = point["members"]
    groups = []
    for seed, top in zip(members["seed_index"][()], members["top"][()]):
        name = f"snapshot_{int(seed)}"
        if name not in members:
            continue
        y_e, y_i = members[name]["y_e"][()], members[name]["y_i"][()]
        inside = (y_e >= bottom) & (y_e <= top - top_cut)
        bins = np.floor((y_e[inside] - (centre[0] - width / 2)) / width).astype(int)
        groups.append((bins, (y_e - y_i)[inside]))
    if len(groups) < 3:
        sys.exit(f"{point.file.filename}: {point.name} has {len(groups)} members with snapshots "
                 "(run with --snapshots; the jackknife needs 3 or more)")
    return groups


def residuals(groups):
    """Per member, the standardised residuals of its disks in groups of MIN_GROUP or more."""
    keyed = []
    for m, (bins, dy) in enumerate(groups):
        n = np.bincount(bins)
        mean = np.bincount(bins, dy) / np.maximum(n, 1)
        keep = n[bins] >= MIN_GROUP
        keyed.append((bins[keep], (dy - mean[bins])[keep], n[bins][keep]))
    size = max(b.max() + 1 for b, _, _ in keyed if b.size)
    squares, dof = np.zeros(size), np.zeros(size)
    for bins, r, n in keyed:
        squares += np.bincount(bins, r * r, size)
        dof += np.bincount(bins, 1.0 - 1.0 / n, size)  # n - 1 a group
    spread = np.sqrt(squares / np.maximum(dof, 1e-300))
    return [r / spread[bins] for bins, r, _ in keyed]


def statistics(z):
    """Skewness, excess kurtosis and the share beyond 3 of the residuals z."""
    m2 = (z * z).mean()
    return np.array([(z ** 3).mean() / m2 ** 1.5, (z ** 4).mean() / m2 ** 2 - 3.0,
                     (np.abs(z) > 3.0).mean()])


def jackknife(per_member):
    """The statistics of all members' residuals and their jackknife errors over members."""
    n = len(per_member)
    whole = statistics(np.concatenate(per_member))
    left = [statistics(np.concatenate(per_member[:k] + per_member[k + 1:])) for k in range(n)]
    return whole, claims.jackknife(left)


def normal_ensembles(groups, trials, rng):
    """The statistics of `trials` ensembles whose disks are normal within the same groups."""
    return np.array([statistics(np.concatenate(residuals(
        [(bins, rng.standard_normal(bins.size)) for bins, _ in groups]))) for _ in range(trials)])


def measure(point, trials=NULL, seed=1):
    groups = slice_groups(point)
    z = residuals(groups)
    value, error = jackknife(z)
    null = normal_ensembles(groups, trials, np.random.default_rng(seed))
    out = {"members": len(z), "disks": int(sum(r.size for r in z))}
    for k, name in enumerate(STATISTICS):
        out[name] = {"value": float(value[k]), "error": float(error[k]),
                     "normal_mean": float(null[:, k].mean()), "normal_sd": float(null[:, k].std()),
                     "t": float((value[k] - null[:, k].mean()) / error[k])}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("file")
    ap.add_argument("--point", default=None, help="point name (default: the file's only point)")
    ap.add_argument("--json", help="append one JSON line here")
    ap.add_argument("--label", default="")
    a = ap.parse_args(argv)
    f = h5py.File(a.file, "r")
    names = list(f["points"])
    if a.point is None and len(names) != 1:
        sys.exit(f"{a.file}: {len(names)} points; name one with --point ({', '.join(names)})")
    name = a.point or names[0]
    if name not in f["points"]:
        sys.exit(f"{a.file}: no point {name} ({', '.join(names)})")
    out = measure(f["points"][name])
    print(f"{a.file} point {name}: {out['disks']} disks of {out['members']} members")
    for s in STATISTICS:
        r = out[s]
        print(f"  {s:16s} {r['value']:8.4f} +- {r['error']:.4f}   normal ensembles "
              f"{r['normal_mean']:8.4f} +- {r['normal_sd']:.4f}   t {r['t']:6.2f}")
    if a.json:
        run = {k: f.attrs[k].item() if hasattr(f.attrs[k], "item") else f.attrs[k]
               for k in ("git_commit", "start_time", "end_time", "seed", "seeds", "mpi_ranks",
                         "kokkos_execution_space") if k in f.attrs}
        env = {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
               "machine": platform.machine(), "python": platform.python_version(),
               "numpy": np.__version__}
        with open(a.json, "a") as j:
            j.write(json.dumps({"label": a.label, "file": os.path.basename(a.file), "point": name,
                                "height": float(f["points"][name].attrs["height"]), **out,
                                "run": run, "env": env}) + "\n")


if __name__ == "__main__":
    main()
