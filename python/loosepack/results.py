"""Reading a loosepack result file (docs/OUTPUT.md) into pandas and xarray objects."""

import contextlib
import os

import h5py
import numpy as np
import pandas as pd
import xarray as xr

# The per-point scalars (attributes <name>_mean, _sem, _n).
SCALARS = ("nu_lower_half", "mean_abs_dy", "nu_initial", "nu_final", "relative_increase")
# Names of the model's parameters among a point's attributes, in the order of docs/OUTPUT.md.
PARAMETERS = (
    "width", "height", "radius", "polydispersity", "disk_density", "gravity", "bond_number",
    "cohesive_force", "cohesion_range", "floor_cohesion", "friction", "rolling_friction",
    "time_step", "capture_radius", "solver_tolerance", "solver_max_sweeps", "solver_newton_every",
    "lower_half_from", "cut_bottom", "cut_top",
)
COUNTS = ("members", "failed")


def _text(value):
    """A string attribute as str: variable-length UTF-8, or the bytes of older files."""
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if isinstance(value, np.ndarray) and value.dtype.kind == "S":
        return value.tobytes().decode("utf-8").rstrip("\0")
    return str(value)


def _value(value):
    """An attribute as a Python str, int or float."""
    if isinstance(value, (bytes, str)) or np.asarray(value).dtype.kind in "SOU":
        return _text(value)
    return np.asarray(value).item()


def _count(value):
    """A count as int: older files stored counts as float64."""
    return int(round(float(value)))


def _get(node, key):
    """node[key], or a KeyError naming the file and the object it lacks (a damaged or edited
    file), where h5py names neither."""
    try:
        return node[key]
    except KeyError:
        raise KeyError(f"{node.file.filename}: {node.name.rstrip('/')}/{key} is missing (the file "
                       "is damaged or was edited)") from None


def _units(dataset):
    return _text(dataset.attrs["units"]) if "units" in dataset.attrs else ""


class Results:
    """A result file: `points` (DataFrame), and per point the profiles, histograms, member
    tables, snapshots and trajectories. Points are named by index (0, 1, ...) or "0001".

    The profiles are xarray Datasets whose variables include `mean` and `count`: read them as
    `ds["mean"]`, since `ds.mean` is the Dataset's method."""

    def __init__(self, path):
        self.path = str(path)
        if not os.path.exists(self.path):
            raise FileNotFoundError(f"{self.path}: no such file")
        try:
            f = h5py.File(self.path, "r")
        except OSError as e:
            raise ValueError(f"{self.path}: not an HDF5 file that can be opened (not a loosepack "
                             f"result file, or damaged?): {e}") from None
        with f:
            if "points" not in f or ("scan_text" not in f and "scan_text" not in f.attrs):
                raise ValueError(f"{self.path}: an HDF5 file but not a loosepack result file (no "
                                 "/points or /scan_text): give the file `loosepack run` wrote")
            self.attrs = {k: _value(v) for k, v in f.attrs.items() if k != "scan_text"}
            self.settings = ({k: _value(v) for k, v in f["settings"].attrs.items()}
                             if "settings" in f else {})
            if "scan_text" in f:
                self.scan_text = _text(f["scan_text"][()])
            else:
                self.scan_text = _text(f.attrs.get("scan_text", ""))
            self.point_names = sorted(f["points"].keys())
            self.points = self._points_table(f)

    def _points_table(self, f):
        rows = []
        for name in self.point_names:
            a = f["points"][name].attrs
            for k in ("protocol",) + COUNTS:
                if k not in a:
                    raise ValueError(f"{self.path}: /points/{name} has no attribute '{k}' (the "
                                     "file is damaged or was edited)")
            row = {"point": int(name), "protocol": _text(a["protocol"])}
            for k in PARAMETERS:
                if k in a:
                    row[k] = float(a[k])
            for k in COUNTS:
                row[k] = _count(a[k])
            for s in SCALARS:
                if s + "_mean" in a:
                    row[s] = float(a[s + "_mean"])
                    row[s + "_sem"] = float(a[s + "_sem"])
                    row[s + "_n"] = _count(a[s + "_n"])
            rows.append(row)
        return pd.DataFrame(rows).set_index("point")

    def _group(self, f, point):
        if isinstance(point, str) and point.isdigit():
            name = "%04d" % int(point)
        elif isinstance(point, (int, np.integer)) and not isinstance(point, bool) and point >= 0:
            name = "%04d" % point
        else:
            raise KeyError("a point is named by its index (0, 1, ...) or as \"0001\", not %r "
                           "(points: %s)" % (point, ", ".join(self.point_names)))
        if name not in f["points"]:
            raise KeyError("%s has no point %s (points: %s)" %
                           (self.path, name, ", ".join(self.point_names)))
        return f["points"][name]

    def _profile(self, point, group, coord):
        """A group of [bins] fields (and [members, bins] rows) as an xarray Dataset."""
        with self._read() as f:
            g = _get(self._group(f, point), group)
            centre = _get(g, "centre")[()]
            seeds = _get(self._group(f, point), "members/seed_index")[()].astype(int)
            data = {}
            for key, d in g.items():
                if not isinstance(d, h5py.Dataset):
                    continue
                v = d[()]
                if v.ndim == 1 and v.shape[0] == centre.shape[0] and key != "centre":
                    data[key] = ((coord,), v, {"units": _units(d),
                                               "long_name": _text(d.attrs.get("long_name", key))})
                elif v.ndim == 2 and v.shape == (seeds.shape[0], centre.shape[0]):
                    data[key] = (("member", coord), v,
                                 {"units": _units(d),
                                  "long_name": _text(d.attrs.get("long_name", key))})
            return xr.Dataset(data, coords={coord: (coord, centre, {"units": "R"}),
                                            "member": ("member", seeds)},
                              attrs={"point": int(g.parent.name.split("/")[-1]),
                                     "file": self.path})

    def nu(self, point):
        """Volume fraction nu(y) by strip: mean, sem, members, rel_fluctuation, depth and the
        per-member rows `member_mean` [member, y] (files from 2026-11-25 on)."""
        return self._profile(point, "nu", "y")

    def nu_deposition(self, point):
        """Deposition density nu_d(y_i) by strip."""
        return self._profile(point, "nu_deposition", "y_i")

    def avalanche(self, point, by="y_e"):
        """Delta y = y_e - y_i binned by y_i or y_e: pooled mean, stddev, count, sem, the bins'
        mean position, and per member (member_mean, member_position, member_count)."""
        if by not in ("y_i", "y_e"):
            raise ValueError("by must be 'y_i' or 'y_e', not %r" % (by,))
        return self._profile(point, "avalanche_by_" + by.replace("_", ""), by)

    def histogram(self, point, cut=False, members=False):
        """The |Delta y| histogram (counts per bin; `cut`: without the bottom and top of the
        deposit) as a DataArray over the bin centres, with each bin's lower edge as a coordinate
        too; `members`: one row per member (dims member, abs_dy; files from 2026-11-26 on), whose
        scatter gives the shapes' errors (a failed member's row is zeros: members(point)'s
        `failure` tells which)."""
        name = ("member_counts" if members else "counts") + ("_cut" if cut else "")
        with self._read() as f:
            g = self._group(f, point)
            h = _get(g, "abs_dy_histogram")
            if name not in h:
                raise KeyError(f"{self.path}: {h.name}/{name} is missing (a file of a program "
                               "before the per-member counts)")
            edges = _get(h, "edges")[()]
            counts = h[name][()]
            seeds = _get(g, "members/seed_index")[()].astype(int) if members else None
        centres = 0.5 * (edges[1:] + edges[:-1])
        coords = {"abs_dy": ("abs_dy", centres, {"units": "R"}),
                  "lower_edge": ("abs_dy", edges[:-1], {"units": "R"})}
        if members:
            coords["member"] = ("member", seeds)
        return xr.DataArray(counts, dims=(("member",) if members else ()) + ("abs_dy",),
                            coords=coords, name=name,
                            attrs={"long_name": "disks per |Delta y| bin", "units": ""})

    def members(self, point):
        """Per-member scalars (seed_index, disks, top, nu_lower_half, steps, sweeps, wall_time,
        failure, capped), one row per member."""
        with self._read() as f:
            g = _get(self._group(f, point), "members")
            cols = {k: d[()] for k, d in g.items()
                    if isinstance(d, h5py.Dataset) and d.ndim == 1}
        df = pd.DataFrame(cols)
        for k in ("seed_index", "disks", "steps", "sweeps", "failure", "capped"):
            if k in df and df[k].notna().all():
                df[k] = df[k].astype(np.int64)
        return df

    @contextlib.contextmanager
    def _read(self):
        """The file, open for reading; what HDF5 itself raises on it (a damaged file) as a
        ValueError naming the file."""
        try:
            with h5py.File(self.path, "r") as f:
                yield f
        except (OSError, RuntimeError) as e:
            raise ValueError(f"{self.path}: the file is damaged or was edited (HDF5: {e})") \
                from None

    @contextlib.contextmanager
    def _member(self, point, kind, seed):
        """One member's group of a kind (snapshot, failure, trajectory), with the file open."""
        with self._read() as f:
            g = _get(self._group(f, point), "members")
            name = "%s_%d" % (kind, seed)
            if name not in g:
                have = sorted(k for k in g.keys() if k.startswith(kind + "_"))
                hint = ""
                if kind == "snapshot":
                    failures = sorted(k for k in g.keys() if k.startswith("failure_"))
                    hint = ("" if have else "; run with --snapshots") + (
                        "; failed members' states at the failure: %s (failure(point, seed))"
                        % ", ".join(failures) if failures else "")
                raise KeyError("%s point %s has no %s (has: %s)%s" % (
                    self.path, point, name, ", ".join(have) or "none", hint))
            yield g[name]

    def snapshot(self, point, seed=0):
        """The final disks of one member (written with --snapshots): x, y_i, y_e, radius and
        dy = y_e - y_i, in deposition order."""
        with self._member(point, "snapshot", seed) as g:
            df = pd.DataFrame({k: _get(g, k)[()] for k in ("x", "y_i", "y_e", "radius")})
        df["dy"] = df["y_e"] - df["y_i"]
        return df

    def failure(self, point, seed=0):
        """A failed member's state at the failure (always written): x, y_i, y_e, radius and the
        velocities vx, vy, w of its disks, with the attributes `failure` (the reason) and
        `member` (its id, for `loosepack run --member`) in DataFrame.attrs."""
        with self._member(point, "failure", seed) as g:
            df = pd.DataFrame({k: _get(g, k)[()]
                               for k in ("x", "y_i", "y_e", "radius", "vx", "vy", "w")})
            df.attrs = {k: (v.decode() if isinstance(v, bytes) else np.asarray(v).item())
                        for k, v in g.attrs.items()}
        return df

    def contacts(self, point, seed=0):
        """The final contacts of one member: disk indices i, j (j = -1: the floor) and the
        normal, tangential forces and rolling moment."""
        with self._member(point, "snapshot", seed) as g:
            df = pd.DataFrame({k[len("contact_"):]: g[k][()] for k in g.keys()
                               if k.startswith("contact_")})
        for k in ("i", "j"):
            df[k] = df[k].astype(np.int64)
        return df

    def trajectory(self, point, seed=0):
        """Sampled positions (time, disk, x, y) of one member (observables.trajectory_every)."""
        with self._member(point, "trajectory", seed) as g:
            df = pd.DataFrame({k: _get(g, k)[()] for k in ("time", "disk", "x", "y")})
        for k in ("time", "disk"):
            df[k] = df[k].astype(np.int64)
        return df

    def fits(self, point):
        """Every result of a point's analysis (docs/OUTPUT.md, "Analysis") as {name: {...}}, names
        as their paths under the point: each fit ("avalanche_by_ye/fit",
        "abs_dy_histogram/shape_cut/gaussian", ...) with coef, error, valid, reduced_chi2 and its
        other attributes; the histograms' verdicts ("abs_dy_histogram/shape_cut": preferred,
        decay_length, gaussian_mean, gaussian_width, ...); protocol C's "collapse_identity" (b',
        a', their predictions and differences, with errors); "nu" (rms_deviation of the final
        density predicted from the deposition density) and "nu/deviation_terms" (that
        deviation's mean and slope with their jackknife errors)."""
        out = {}
        with self._read() as f:
            g = self._group(f, point)

            def visit(name, obj):
                if not isinstance(obj, h5py.Group):
                    return
                attrs = {k: _value(v) for k, v in obj.attrs.items()}
                if "coef" in obj:
                    out[name] = dict(attrs, coef=obj["coef"][()], error=obj["error"][()])
                elif attrs and (name in ("collapse_identity", "nu", "nu/deviation_terms") or
                                name.startswith("abs_dy_histogram/shape")):
                    out[name] = attrs
            g.visititems(visit)
        return out

    def across(self):
        """The fits across scan points (`analysis/*`: increase_vs_log_height,
        increase_vs_nu_initial, quadratic_vs_height, slice_vs_height) that the scan has the points
        for, as {name: {coef, error, scan_points, valid, reduced_chi2, ...}}; scan_points are the
        indices of the points each went through."""
        out = {}
        with self._read() as f:
            for name, g in f.get("analysis", {}).items():
                attrs = {k: _value(v) for k, v in g.attrs.items()}
                if not attrs.get("valid", 0) or "coef" not in g:
                    continue
                out[name] = dict(attrs, coef=g["coef"][()], error=g["error"][()],
                                 scan_points=g["scan_points"][()].astype(int)
                                 if "scan_points" in g else None)
        return out

    def events(self, point):
        """Protocol A's deposition events as an xarray Dataset over logarithmic bins (`bin`, with
        their lower and upper edges): `downward_counts` (by summed downward displacement, R),
        `moved_counts` (by disks moved), `steps_counts` (by steps to rest), and per member
        `member_*_counts` [member, bin] (files from 2026-11-26 on); attribute `without_motion`."""
        with self._read() as f:
            g = self._group(f, point)
            if "events" not in g:
                raise KeyError(f"{self.path}: point {point} has no events (protocol A only)")
            e = g["events"]
            edges = _get(e, "edges")[()]
            seeds = _get(g, "members/seed_index")[()].astype(int)
            data = {}
            for key, d in e.items():
                if key == "edges":
                    continue
                dims = ("bin",) if d.ndim == 1 else ("member", "bin")
                data[key] = (dims, d[()], {"long_name": _text(d.attrs.get("long_name", key))})
            attrs = {k: _value(v) for k, v in e.attrs.items()}
        coords = {"bin": ("bin", np.sqrt(edges[:-1] * edges[1:])),
                  "lower_edge": ("bin", edges[:-1]), "upper_edge": ("bin", edges[1:]),
                  "member": ("member", seeds)}
        return xr.Dataset(data, coords=coords, attrs=dict(attrs, point=point, file=self.path))

    def __repr__(self):
        return "<loosepack.Results %s: %d points>" % (self.path, len(self.point_names))


def load(path):
    """Open a loosepack result file; see Results."""
    return Results(path)
