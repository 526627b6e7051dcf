#!/usr/bin/env python3
"""Compares two loosepack result files bit for bit: every dataset and every attribute, except
what records the run rather than the results (times, the number of MPI ranks, the batch size,
the shard files a merged file came from, and members/wall_time, the seconds each member took),
and what `--except NAME` names (a dataset's or attribute's name; repeatable).
Exit 0 when equal, 1 with the first differences listed."""
import sys

import h5py
import numpy as np

RUN_ATTRIBUTES = {"start_time", "end_time", "wall_seconds", "mpi_ranks", "batch_size",
                  "merged_from"}
RUN_DATASETS = {"wall_time"}


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
    args = sys.argv[1:]
    skip = [args[k + 1] for k in range(len(args) - 1) if args[k] == "--except"]
    files = [a for k, a in enumerate(args) if a != "--except" and (k == 0 or args[k - 1] != "--except")]
    if len(files) != 2 or (args and args[-1] == "--except"):
        print("usage: h5_equal.py A.h5 B.h5 [--except NAME]...", file=sys.stderr)
        return 2
    a, b = items(files[0], skip), items(files[1], skip)
    diff = sorted(k for k in a.keys() | b.keys() if a.get(k) != b.get(k))
    if diff:
        print(f"{files[0]} and {files[1]} differ in {len(diff)} items, e.g.:")
        for k in diff[:10]:
            print("  " + k)
        return 1
    print(f"equal: {len(a)} datasets and attributes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
