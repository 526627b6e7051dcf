#!/usr/bin/env python3
"""Pools independent paired comparisons of one scene into one (docs/PERFORMANCE.md, "Relaxation
regions"): each line of the JSONL files is one `tools/compare.py --paired --json` record of
the same point, run on other members (another scan seed). Each quantity's paired difference
B - A is averaged over the records with weights 1/error^2, its error 1/sqrt(sum of the
weights), and the pooled difference is given in those errors, as compare.py judges a paired
quantity (within --sigma, 2 by default).

    /usr/bin/python3 bench/combine_paired.py RECORDS.jsonl [MORE.jsonl ...] [--sigma 2]

Only the quantities whose rows carry `paired_difference` and `paired_error` in every record are
pooled (the scalars and the profile fits; the profiles' and histograms' chi2 are not). Exits 2
on unusable input: fewer than two records, or a record without a paired quantity (one of
compare.py without --paired).
"""
import argparse
import json
import math
import sys


def unusable(message):
    print(f"combine_paired.py: {message}", file=sys.stderr)
    sys.exit(2)


def read_records(paths):
    records = []
    for path in paths:
        try:
            with open(path) as f:
                for number, line in enumerate(f, 1):
                    if line.strip():
                        records.append((f"{path}:{number}", json.loads(line)))
        except (OSError, json.JSONDecodeError) as e:
            unusable(f"{path}: {e}")
    if len(records) < 2:
        unusable("give two or more records to pool")
    return records


def pooled(rows):
    """(difference, error) pooled from (difference, error) pairs by inverse-variance weights."""
    weights = [1.0 / e ** 2 for _, e in rows]
    difference = sum(w * d for w, (d, _) in zip(weights, rows)) / sum(weights)
    return difference, 1.0 / math.sqrt(sum(weights))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("records", nargs="+")
    ap.add_argument("--sigma", type=float, default=2.0)
    args = ap.parse_args()
    records = read_records(args.records)
    by_quantity = {}
    for where, record in records:
        paired = [row for row in record.get("rows", [])
                  if row.get("paired_difference") is not None and row.get("paired_error")]
        if not paired:
            unusable(f"{where}: no paired quantity (give records of compare.py --paired --json)")
        for row in paired:
            by_quantity.setdefault(row["quantity"], []).append(
                (row["paired_difference"], row["paired_error"]))
    print("| quantity | " + " | ".join(f"B - A, record {k + 1}" for k in range(len(records)))
          + " | pooled B - A | distance | within |")
    print("|---" * (len(records) + 4) + "|")
    for quantity, rows in by_quantity.items():
        if len(rows) != len(records):
            continue
        d, e = pooled(rows)
        z = abs(d) / e
        print(f"| {quantity} | " + " | ".join(f"{a:.4g} +- {b:.2g}" for a, b in rows)
              + f" | {d:.4g} +- {e:.2g} | {z:.2f} sigma | {'yes' if z <= args.sigma else 'NO'} |")
    for k, (where, record) in enumerate(records, 1):
        print(f"record {k}: {where}: {record.get('label', '')[:160]}")


if __name__ == "__main__":
    main()
