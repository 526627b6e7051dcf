#!/usr/bin/env python3
"""How often tools/claims.py rejects a right profile model, by the term the model lacks and by
the chi2 of its residuals, on synthetic ensembles whose members deviate from the true profile
together over neighbouring bins (docs/OUTPUT.md, "Analysis"; docs/REPRODUCTION.md, "Checking
the claims").

    /usr/bin/python3 bench/claims_calibration.py [TRIALS] [--json OUT.jsonl]

Each ensemble has n members (4, 8, 16) over 13 bins from 20 to 140 R, 20 disks a bin; a member's
deviation is an AR(1) series with correlation rho (0, 0.67, 0.93) between neighbouring bins and
standard deviation 0.3 R, about a true parabola and a true line. Per setting it prints the share
of TRIALS (default 2 000) ensembles in which the next term's t is beyond its two-sided 99 % bound
(the cubic term of the parabola, the quadratic term of the line: claims.py's verdicts) and in
which the model's chi2 exceeds its 99 % quantile. A right model should be rejected about 1 % of
the time. With --json one line per setting is appended.
"""
import argparse
import json
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
import claims  # noqa: E402

CENTRE = np.linspace(20.0, 140.0, 13)
TRUTH = {2: 0.5 - 0.02 * CENTRE + 1e-4 * CENTRE ** 2, 1: 0.5 - 0.02 * CENTRE}


def rejections(members, rho, degree, trials, rng):
    """(share rejected by the next term's t, share rejected by the chi2) of a true polynomial of
    `degree` over `trials` ensembles."""
    bound = claims.t_quantile(members - 1)
    by_t = by_chi2 = 0
    for _ in range(trials):
        e = np.empty((members, CENTRE.size))
        e[:, 0] = rng.normal(size=members)
        for b in range(1, CENTRE.size):
            e[:, b] = rho * e[:, b - 1] + math.sqrt(1 - rho * rho) * rng.normal(size=members)
        group = {"member_count": np.full((members, CENTRE.size), 20.0),
                 "member_mean": TRUTH[degree] + 0.3 * e,
                 "member_position": np.tile(CENTRE, (members, 1)), "centre": CENTRE}
        profile = claims.Profile(group, -math.inf, math.inf)
        by_t += abs(claims.top_t(profile.fit(degree + 1))) > bound
        _, _, chi2, dof = profile.fit(degree)
        by_chi2 += chi2 > claims.chi2_quantile99(dof)
    return by_t / trials, by_chi2 / trials


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("trials", nargs="?", type=int, default=2000)
    parser.add_argument("--json")
    args = parser.parse_args()
    print("members  rho   model     next term's t  chi2")
    for members in (4, 8, 16):
        for rho in (0.0, 0.67, 0.93):
            for degree, model in ((2, "parabola"), (1, "line")):
                rng = np.random.default_rng(1000 * members + int(100 * rho) + degree)
                t, chi2 = rejections(members, rho, degree, args.trials, rng)
                print(f"{members:7d}  {rho:4.2f}  {model:8s}  {100 * t:11.2f} %  {100 * chi2:5.2f} %")
                if args.json:
                    with open(args.json, "a") as f:
                        f.write(json.dumps({"members": members, "rho": rho, "model": model,
                                            "trials": args.trials, "rejected_by_next_term": t,
                                            "rejected_by_chi2": chi2}) + "\n")


if __name__ == "__main__":
    main()
