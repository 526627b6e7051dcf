#!/usr/bin/env python3
"""Summary of a paper-size member timed across runs (bench/paper_size_member.sh).

    /usr/bin/python3 bench/paper_size_member.py OUT_DIR/progress.tsv

progress.tsv holds, once a minute and at each run's end, the run's CPU seconds and the disks
deposited. A resumed run starts again from the member's last checkpoint, so the CPU of the runs
before it is added in full (the work redone after a stop counts, as it cost). Prints one JSON line: the CPU so far, the
disks, the CPU at each doubling of the disks and the exponent p of CPU = A disks^p fitted over
the samples from 1 000 disks on.
"""
import json
import math
import sys


def cumulative(rows):
    """(cpu, disks) with each run's CPU added to the CPU of the runs before it."""
    out, before, run, last = [], 0.0, None, 0.0
    for r, cpu, disks in rows:
        if r != run:
            before += last
            run, last = r, 0.0
        last = cpu
        out.append((before + cpu, disks))
    return out


def exponent(points, smallest=1000):
    """Least-squares slope of log CPU against log disks, or None with fewer than 3 points."""
    xy = [(math.log(d), math.log(c)) for c, d in points if d >= smallest and c > 0]
    if len(xy) < 3 or max(x for x, _ in xy) - min(x for x, _ in xy) < 0.1:
        return None
    mx = sum(x for x, _ in xy) / len(xy)
    my = sum(y for _, y in xy) / len(xy)
    sxx = sum((x - mx) ** 2 for x, _ in xy)
    return sum((x - mx) * (y - my) for x, y in xy) / sxx


def main(path):
    rows = []
    with open(path) as f:
        next(f)  # header
        for line in f:
            run, _, cpu, disks = line.split("\t")
            rows.append((int(run), float(cpu), int(disks)))
    if not rows:
        sys.exit(f"{path}: no samples yet")
    points = cumulative(rows)
    at_doubling, next_disks = [], 500
    for cpu, disks in points:
        if disks >= next_disks:
            at_doubling.append([disks, round(cpu, 1)])
            while next_disks <= disks:
                next_disks *= 2
    p = exponent(points)
    print(json.dumps({"runs": rows[-1][0], "cpu_s": round(points[-1][0], 1),
                      "disks": points[-1][1], "cpu_s_at_disks": at_doubling,
                      "exponent_from_1000_disks": None if p is None else round(p, 2)}))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
