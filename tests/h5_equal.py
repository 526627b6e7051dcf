#!/usr/bin/env python3
"""Compares two loosepack result files bit for bit: every dataset and every attribute, except
what records the run rather than the results (times, the number of MPI ranks, the batch size,
the files a merged file came from, and members/wall_time and /members_encoded, which hold the
seconds each member took),
and what `--except NAME` names (a dataset's or attribute's name; repeatable).
Exit 0 when equal, 1 with the first differences listed."""
import argparse
import sys

import h5py
import numpy as np

RUN_ATTRIBUTES = {"start_time", "end_time", "wall_seconds", "mpi_ranks", "batch_size",
                  "merged_from"}
RUN_DATASETS = {"wall_time", "members_encoded"}  # the latter holds each member's wall time too


def items(path, skip=()):
    datasets, attributes = RUN_DATASETS | set(skip), RUN_ATTRIBUTES | set(skip)
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and name.split("/")[-1] not in datasets:
                out["D " + name] = np.asarray(obj[()]).tobytes()
            for key, val in obj.attrs.items():
                if key not in attributes:
                    out["A " + name + "@" + key] = np.asarray(val).tobytes()
        for key, val in f.attrs.items():
            if key not in attributes:
                out["A /@" + key] = np.asarray(val).tobytes()
        f.visititems(visit)
    return out


def main():
    ap = argparse.ArgumentParser(description="Compares two loosepack result files bit for bit.")
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--except", dest="skip", action="append", default=[], metavar="NAME",
                    help="a dataset's or attribute's name to leave out (repeatable)")
    args = ap.parse_args()  # bad arguments: exit 2
    a, b = items(args.a, args.skip), items(args.b, args.skip)
    diff = sorted(k for k in a.keys() | b.keys() if a.get(k) != b.get(k))
    if diff:
        print(f"{args.a} and {args.b} differ in {len(diff)} items, e.g.:")
        for k in diff[:10]:
            print("  " + k)
        return 1
    print(f"equal: {len(a)} datasets and attributes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
