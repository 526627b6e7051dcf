#!/usr/bin/env python3
"""How often tools/claims.py rejects a right claim that the cut |Delta y| histogram's skew is its
height slices' Gaussians' sum's (SliceMixture, mixture_terms; docs/REPRODUCTION.md, "Why the
Gaussian gives way in taller boxes"), on synthetic ensembles whose disks come in avalanches.

    /usr/bin/python3 bench/slice_sum_calibration.py [TRIALS] [--json OUT.jsonl]

Each member is a box 180 R tall holding about 1 400 disks, deposited in avalanches: each avalanche
lands about a height y0 (uniform over the box; its disks normal about it with a spread of 2 R,
kept inside the box) and moves its disks by the profile there, Delta y = -12 sin(pi y / H) (about
the shape and depth of the H = 240 ensemble's), plus an offset shared by the avalanche's disks and
a jitter of each disk's own, normal, with 1.5 R and 2.5 R of spread (2.9 R in all, as the scatter
about the profile at H = 180-240). Avalanche sizes are geometric with mean 8, at most 40 (`light`),
or a power law P(s) ~ s^-2 from 1 to 500 disks (`heavy`). The profile is binned by y_e in bins of
4 R and the cut histogram (20 R off the bottom and the top) in bins of 0.5 R up to 40 R, as the
program writes them. So the disks of a height are a sum of normals about the profile, as the claim
assumes, but they come in lumps that move together. Per setting it prints the share of TRIALS
(default 200) ensembles whose claim fails (the cubic term's difference beyond the two-sided 99 %
bound: 1 % for a calibrated test) and the mean of the sum's cubic over the measured error (how
far the profile alone puts the Gaussian's cubic term from zero). With --json one line per setting
is appended.
"""
import argparse
import io
import json
import os
import sys

import h5py
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
import claims  # noqa: E402

H, BIN, CUT = 180.0, 4.0, 20.0
EDGES = np.arange(0.0, 40.01, 0.5)
CENTRE = np.arange(BIN / 2, H, BIN)
DISKS = 1400
SPREAD_Y, SHARED, OWN = 2.0, 1.5, 2.5
POWER_SIZES = np.arange(1, 501)
POWER_P = POWER_SIZES ** -2.0 / (POWER_SIZES ** -2.0).sum()


def profile(y):
    return -12.0 * np.sin(np.pi * y / H)


def member(rng, sizes):
    """One member's disks: (y_e, Delta y)."""
    ys, dys = [], []
    disks = 0
    while disks < DISKS:
        s = (min(40, rng.geometric(1 / 8)) if sizes == "light"
             else rng.choice(POWER_SIZES, p=POWER_P))
        y = np.clip(rng.uniform(0.0, H) + SPREAD_Y * rng.normal(size=s), 0.0, H - 1e-9)
        ys.append(y)
        dys.append(profile(y) + SHARED * rng.normal() + OWN * rng.normal(size=s))
        disks += s
    return np.concatenate(ys), np.concatenate(dys)


def ensemble_point(rng, members, sizes):
    """An in-memory result file's point with the datasets SliceMixture and Histogram read."""
    f = h5py.File(io.BytesIO(), "w")
    g = f.create_group("points/0000")
    g.attrs.update({"protocol": "A", "bond_number": 1e3, "height": H, "cut_bottom": CUT,
                    "cut_top": CUT})
    shape = (members, CENTRE.size)
    count, mean, pos = np.zeros(shape), np.full(shape, np.nan), np.full(shape, np.nan)
    hist = np.zeros((members, EDGES.size - 1))
    pooled = [[] for _ in CENTRE]
    for m in range(members):
        y, dy = member(rng, sizes)
        b = np.floor(y / BIN).astype(int)
        for k in np.unique(b):
            here = b == k
            count[m, k], mean[m, k], pos[m, k] = here.sum(), dy[here].mean(), y[here].mean()
            pooled[k].append(dy[here])
        cut = (y >= CUT) & (y <= H - CUT)
        hist[m] = np.histogram(np.abs(dy[cut]), EDGES)[0]
    a = g.create_group("avalanche_by_ye")
    a["centre"], a["member_count"], a["member_mean"], a["member_position"] = \
        CENTRE, count, mean, pos
    a["mean"] = [np.concatenate(d).mean() if d else np.nan for d in pooled]
    a["stddev"] = [np.concatenate(d).std(ddof=1) if d else np.nan for d in pooled]
    g["abs_dy_histogram/edges"], g["abs_dy_histogram/member_counts_cut"] = EDGES, hist
    g["members/top"], g["members/failure"] = np.full(members, H), np.zeros(members, np.int32)
    return f, g


def rejections(members, sizes, trials, rng):
    """(ensembles judged, how many of them reject the right sum, the mean of the sum's cubic over
    the measured error) over `trials` synthetic ensembles."""
    failed, sum_t = 0, []
    for _ in range(trials):
        f, g = ensemble_point(rng, members, sizes)
        with f:
            hist = claims.Histogram(g["abs_dy_histogram"], "synthetic")
            terms = claims.mixture_terms(hist, claims.SliceMixture(g, hist))
        if terms is None:
            continue
        cubic, err, cubic_sum, t = terms[1]
        failed += abs(t) > claims.t_quantile(members - 1)
        sum_t.append(cubic_sum / err)
    return len(sum_t), failed, float(np.mean(sum_t))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("trials", nargs="?", type=int, default=200)
    ap.add_argument("--json", help="append one JSON line per setting to this file")
    args = ap.parse_args()
    for sizes in ("light", "heavy"):
        for members in (8, 16):
            rng = np.random.default_rng(1000 * members + (sizes == "heavy"))
            trials, failed, sum_t = rejections(members, sizes, args.trials, rng)
            line = {"study": "slice_sum_calibration", "sizes": sizes, "members": members,
                    "trials": trials, "rejected": failed / trials,
                    "mean_sum_cubic_over_error": sum_t,
                    "command": "/usr/bin/python3 bench/slice_sum_calibration.py "
                               f"{args.trials} --json OUT"}
            print(f"{sizes:5s} avalanches, {members:2d} members: the right sum rejected in "
                  f"{failed} of {trials} ({100 * failed / trials:.1f} %); the sum's cubic over "
                  f"the measured error {sum_t:.2f} on average")
            if args.json:
                with open(args.json, "a") as out:
                    out.write(json.dumps(line) + "\n")


if __name__ == "__main__":
    main()
