#!/usr/bin/env python3
"""Checks the paper's qualitative claims on a loosepack result file and says which hold.

    python3 tools/claims.py out/claims.h5

For every scan point it can judge (from the fits the program stored, docs/OUTPUT.md):

  A, 0 < Bo < inf   the avalanche profile Delta y(y_e) is a parabola with positive curvature:
                    c2 > 0 by at least two standard errors (paper figs. 6, 7, 11)
  A, Bo = 0         the |Delta y| histogram is better described by an exponential (fig. 9)
  A, Bo >= 1e3      the |Delta y| histogram is better described by a Gaussian (fig. 8)
  C                 Delta y is a straight line in y_e and in y_i (chi2/dof of the lines below 3),
                    and the coefficient identity b' = b/(1+b), a' = a/(1+b) holds within two
                    combined standard errors (figs. 14, 15)

and, across the points of a scan (the fits in `analysis/`, made when three or more points
differ only in that variable):

  A, heights        the curvature of Delta y(y_e) scales like 1/H: the exponent p of
                    abs(c2) = A H^p within two standard errors of -1 (fig. 7)
  C, heights        dnu/nu_i grows with ln H: slope above zero by two standard errors (fig. 16)
  C, r_capt         dnu/nu_i falls with nu_i as a power law: exponent below zero by two
                    standard errors (fig. 17; the paper's is -1.64)

Histogram claims use the cut histogram (`shape_cut`: without the bottom and top
`cut_bottom`/`cut_top` of the deposit, as the paper does) when it has a verdict, else the whole
one. Prints one line per claim (PASS or FAIL with the numbers) and exits with status 1 when any
claim fails, 2 when the file has nothing to judge. Uses Debian's python3-h5py.
"""
import math
import sys

try:
    import h5py
except ImportError as e:  # pragma: no cover
    sys.exit(f"claims.py: {e}; install python3-h5py (scripts/install-deps.sh)")


def fail_missing(path, name):
    sys.exit(f"claims.py: {path}: '{name}' is missing (was the file written by loosepack? "
             f"`loosepack analyse {path}` adds the current analysis to a file of an older one)")


def fit(group, path):
    for part in ("coef", "error"):
        if part not in group:
            fail_missing(path, f"{group.name}/{part}")
    return list(group["coef"][()]), list(group["error"][()]), dict(group.attrs)


def text(v):
    return v.decode() if isinstance(v, bytes) else str(v)


def histogram_verdict(point, path):
    name = "abs_dy_histogram"
    if name not in point:
        fail_missing(path, f"{point.name}/{name}")
    h = point[name]
    for which in ("shape_cut", "shape"):
        if which not in h:
            fail_missing(path, f"{h.name}/{which}")
        preferred = text(h[which].attrs["preferred"])
        if preferred != "none":
            return which, preferred, h[which]
    return "shape", "none", h["shape"]


def check_point(point, path):
    """Yields (claim, ok, detail) for one scan point."""
    a = point.attrs
    protocol, bo = text(a["protocol"]), float(a["bond_number"])
    where = f"point {point.name.split('/')[-1]} ({protocol}, Bo = {bo:g}, H = {a['height']:g})"
    if protocol == "A" and 0 < bo < math.inf:
        coef, err, attrs = fit(point["avalanche_by_ye/fit"], path)
        ok = bool(attrs.get("valid", 1)) and len(coef) == 3 and coef[2] > 2 * err[2]
        c2 = f"{coef[2]:.3g} +- {err[2]:.2g}" if len(coef) == 3 else "no fit"
        yield (f"{where}: Delta y(y_e) is a parabola with positive curvature", ok, f"c2 = {c2}")
    if protocol == "A" and (bo == 0 or 1e3 <= bo < math.inf):  # at Bo = inf nothing moves
        expected = "exponential" if bo == 0 else "gaussian"
        which, preferred, g = histogram_verdict(point, path)
        detail = (f"{which}: preferred {preferred}; chi2 exponential "
                  f"{g['exponential'].attrs['chi2']:.3g}, gaussian {g['gaussian'].attrs['chi2']:.3g}")
        yield (f"{where}: |Delta y| histogram is {expected}", preferred == expected, detail)
    if protocol == "C":
        lines_ok, rchi = True, []
        for key in ("avalanche_by_ye/fit", "avalanche_by_yi/fit"):
            coef, err, attrs = fit(point[key], path)
            r = float(attrs.get("reduced_chi2", math.nan))
            rchi.append(f"{key.split('/')[0]} chi2/dof {r:.2g}")
            lines_ok = lines_ok and bool(attrs.get("valid", 1)) and len(coef) == 2 and r < 3
        yield (f"{where}: Delta y is a straight line in y_e and y_i", lines_ok, ", ".join(rchi))
        if "collapse_identity" not in point:
            fail_missing(path, f"{point.name}/collapse_identity")
        c = point["collapse_identity"].attrs
        for p in ("b_prime", "a_prime"):
            v, e = float(c[p]), float(c[p + "_error"])
            w, f = float(c[p + "_predicted"]), float(c[p + "_predicted_error"])
            ok = abs(v - w) <= 2 * math.hypot(e, f)
            name = p.replace("_prime", "'")
            yield (f"{where}: {name} = {p[0]}/(1+b)", ok, f"{v:.3g} +- {e:.2g} against {w:.3g} +- {f:.2g}")


def check_scan(f, path):
    """Yields (claim, ok, detail) for the fits across scan points that the file has."""
    if "analysis" not in f:
        fail_missing(path, "/analysis")
    a = f["analysis"]
    claims = (
        ("quadratic_vs_height", "A across heights: curvature c2 of Delta y(y_e) scales like 1/H",
         lambda p, e: abs(p + 1) <= 2 * e, "exponent p of abs(c2) = A H^p"),
        ("slice_vs_height", "A across heights: the slice model's a stays fixed (Delta y = H f(y/H))",
         lambda p, e: abs(p) <= 2 * e, "exponent p of a = A H^p"),
        ("increase_vs_log_height", "C across heights: dnu/nu_i grows with ln H",
         lambda p, e: p > 2 * e, "slope against ln H"),
        ("increase_vs_nu_initial", "C across capture radii: dnu/nu_i falls with nu_i (power law)",
         lambda p, e: p < -2 * e, "exponent p of dnu/nu_i = A nu_i^p"),
    )
    for key, claim, holds, what in claims:
        if key not in a:  # a file written before this fit existed
            print(f"claims.py: {path}: no /analysis/{key} (an older file): `loosepack analyse "
                  f"{path}` adds it", file=sys.stderr)
            continue
        if not a[key].attrs.get("valid", 0):
            continue  # the scan has no three points differing in that variable
        coef, err, attrs = fit(a[key], path)
        p, e = float(coef[1]), float(err[1])
        yield (claim, holds(p, e),
               f"{what} = {p:.3g} +- {e:.2g}, chi2/dof {float(attrs.get('reduced_chi2', math.nan)):.2g}")


def main():
    if len(sys.argv) != 2 or sys.argv[1].startswith("-"):
        sys.exit("usage: claims.py RESULT.h5")
    path = sys.argv[1]
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        sys.exit(f"claims.py: {path}: not a readable HDF5 file ({e})")
    with f:
        if "points" not in f:
            fail_missing(path, "/points")
        results = []
        for name in sorted(f["points"]):
            results.extend(check_point(f["points"][name], path))
        results.extend(check_scan(f, path))
    if not results:
        print(f"claims.py: {path}: no scan point the claims speak about")
        sys.exit(2)
    for claim, ok, detail in results:
        print(f"{'PASS' if ok else 'FAIL'}  {claim}  [{detail}]")
    failed = sum(1 for _, ok, _ in results if not ok)
    print(f"{len(results) - failed} of {len(results)} claims hold")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
