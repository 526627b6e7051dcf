#!/usr/bin/env python3
"""MPI scaling of an ensemble on this machine: the same scan run without mpirun and under
`mpirun -np K` for each K, repeated and interleaved (this machine is noisy), every output checked
identical to the run without mpirun (tests/h5_equal.py), one JSON record per run on stdout and a
last record with the best time per rank count, the speed-up and the efficiency against the best
run without mpirun.

    /usr/bin/python3 bench/mpi_scaling.py --exe build/loosepack [--ranks 1,2] [--repeat 2] [--tiny] [SCAN]

Without SCAN it runs the documented ensemble (docs/PERFORMANCE.md, "MPI scaling"): 16 protocol-C
members, 32 R x 48 R, Bo = 1e3, h = 0.003, batches of 4. --tiny (the CI run) is 4 small members.
Uses Debian's python3-h5py (scripts/install-deps.sh) and OpenMPI's mpirun.
"""
import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time

try:
    import h5py
except ImportError as e:  # pragma: no cover
    sys.exit(f"mpi_scaling.py: {e}; install python3-h5py (scripts/install-deps.sh)")

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))
from h5_equal import items  # noqa: E402  (the one comparison of result files)

DEFAULT_SCAN = """[scan]
name = "mpi_scaling"
protocol = "C"
seeds = 16
batch_size = 4
[system]
width = 32
height = 48
bond_number = 1000
time_step = 0.003
[observables]
lower_half_from = 4
"""

TINY_SCAN = """[scan]
name = "mpi_scaling_tiny"
protocol = "C"
seeds = 4
batch_size = 1
[system]
width = 12
height = 12
bond_number = 30
[observables]
lower_half_from = 2
"""


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def mpirun_version(mpirun):
    out = subprocess.run([mpirun, "--version"], capture_output=True, text=True).stdout
    return out.splitlines()[0].strip() if out else "unknown"


def text(v):
    return v.decode() if isinstance(v, bytes) else v


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scan", nargs="?", help="scan file (default: the documented ensemble)")
    ap.add_argument("--exe", default=os.path.join(HERE, "..", "build", "loosepack"))
    ap.add_argument("--ranks", default="1,2", help="rank counts under mpirun (default 1,2)")
    ap.add_argument("--repeat", type=int, default=2, help="repetitions of every run (default 2)")
    ap.add_argument("--tiny", action="store_true", help="4 small members, once (CI)")
    args = ap.parse_args()
    try:
        ranks = [int(k) for k in args.ranks.split(",")]
    except ValueError:
        sys.exit(f"mpi_scaling.py: --ranks {args.ranks}: expected rank counts like 1,2")
    if not ranks or min(ranks) < 1 or args.repeat < 1:
        sys.exit("mpi_scaling.py: --ranks needs counts >= 1 and --repeat at least 1")
    if not os.access(args.exe, os.X_OK):
        sys.exit(f"mpi_scaling.py: {args.exe}: no loosepack executable (build first, or --exe)")
    mpirun = shutil.which("mpirun") or shutil.which("mpiexec")
    if mpirun is None:
        sys.exit("mpi_scaling.py: no mpirun on PATH (scripts/install-deps.sh installs OpenMPI)")
    if args.scan and not os.path.exists(args.scan):
        sys.exit(f"mpi_scaling.py: {args.scan}: no such file")
    repeat = 1 if args.tiny else args.repeat
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1")

    with tempfile.TemporaryDirectory(prefix="loosepack-mpi-") as work:
        scan = args.scan
        if scan is None:
            scan = os.path.join(work, "scan.toml")
            with open(scan, "w") as f:
                f.write(TINY_SCAN if args.tiny else DEFAULT_SCAN)
        runs = [("serial", 0)] + [(f"np{k}", k) for k in ranks]
        walls = {name: [] for name, _ in runs}
        reference = None
        meta = None
        for rep in range(repeat):
            for name, k in runs:
                out = os.path.join(work, f"{name}-{rep}.h5")
                cmd = [args.exe, "run", scan, "-o", out, "-q"]
                if k > 0:
                    cmd = [mpirun, "-np", str(k)] + cmd
                load = os.getloadavg()
                t0 = time.perf_counter()
                r = subprocess.run(cmd, env=env, capture_output=True, text=True)
                wall = time.perf_counter() - t0
                if r.returncode != 0:
                    sys.exit(f"mpi_scaling.py: {' '.join(cmd)} failed ({r.returncode}):\n{r.stderr}")
                if reference is None:
                    reference = items(out)
                    with h5py.File(out, "r") as f:
                        meta = {key: text(f.attrs[key]) for key in
                                ("compiler", "cxx_flags", "git_commit", "kokkos_execution_space",
                                 "scan_name")}
                        meta["members"] = int(sum(len(f["points"][p]["members"]["seed_index"])
                                                  for p in f["points"]))
                    same = True
                else:
                    got = items(out)
                    diff = sorted(key for key in got.keys() | reference.keys()
                                  if got.get(key) != reference.get(key))
                    same = not diff
                if not same:
                    sys.exit(f"mpi_scaling.py: {name} (repetition {rep + 1}) wrote results that "
                             f"differ from the first run's in {len(diff)} items, e.g. {diff[:5]}")
                walls[name].append(wall)
                os.remove(out)
                print(json.dumps({"study": "mpi", "run": name, "ranks": max(k, 1),
                                  "mpirun": k > 0, "repetition": rep + 1, "wall_s": round(wall, 3),
                                  "identical_to_first": same,
                                  "load_average_before": [round(x, 2) for x in load]}),
                      flush=True)
        best_serial = min(walls["serial"])
        summary = {}
        for name, k in runs:
            best = min(walls[name])
            summary[name] = {"ranks": max(k, 1), "best_wall_s": round(best, 3),
                             "walls_s": [round(w, 3) for w in walls[name]],
                             "speedup": round(best_serial / best, 3),
                             "efficiency": round(best_serial / best / max(k, 1), 3)}
        record = {
            "study": "mpi_summary",
            "env": {"date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                    "cpu": cpu_model(), "cores": os.cpu_count(),
                    "compiler": meta["compiler"], "flags": meta["cxx_flags"],
                    "kokkos_backend": meta["kokkos_execution_space"],
                    "commit": meta["git_commit"], "mpirun": mpirun_version(mpirun)},
            "scan": meta["scan_name"], "members": meta["members"], "repeat": repeat,
            "runs": summary,
        }
        print(json.dumps(record), flush=True)


if __name__ == "__main__":
    main()
