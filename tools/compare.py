#!/usr/bin/env python3
"""Compares the observables of two loosepack result files, point by point, within their errors.

    /usr/bin/python3 tools/compare.py A.h5 B.h5 [--sigma 2] [--paired] [--json out.jsonl] [--label TEXT]

For two runs of the same scan points with different settings (relaxation regions against the
whole system, two time steps, two program versions), prints per point one row per quantity:
each file's value with its standard error, and how far apart they are in combined standard
errors, sqrt(e_A^2 + e_B^2) (a pair whose files define the observables otherwise, their bands,
strips, bins, stop rule or event threshold, is said to be); an unpaired scalar also gives A/B,
its error from the two relative errors to first order (the JSON's `ratio`, `ratio_error`), where
B lies more than two of its errors from 0:

  nu_lower_half, mean abs(Delta y) the point's ensemble means and standard errors (protocol C
                                  also nu_i and dnu/nu_i)
  avalanche profile fits          a, b, c of Delta y = a + b y + c y^2 against y_i and y_e
                                  (the program's fits, errors a jackknife over the members)
  nu(y)                           every strip both ensembles fill with two or more members:
                                  chi2 = sum z^2 over the strips (each z a normal deviate of
                                  the same tail probability as the strip's Welch t, below),
                                  judged against its bound from splits of the members (below),
                                  and the largest abs(z)
  abs(Delta y) histogram          the cut histogram's shape: a Gaussian or an exponential must
                                  be acceptable in both files as the program judges each shape
                                  (its next two terms within their bounds, docs/OUTPUT.md; the
                                  program's verdict `preferred` between two shapes that both fit
                                  may differ by chance), or neither verdict be a shape; each bin's
                                  fraction of the disks, mean and standard error over the
                                  members, chi2 of the bins' Welch t as normal deviates (below)
                                  over the bins with 10 disks or more in both, against its bound
                                  from splits of the members
  avalanche events                the mean of log10(disks moved) of the events that moved disks,
                                  with its error a jackknife over the members; and the members'
                                  fractions of their events per bin of size and of steps, as
                                  the histogram's, bins merged from the top until each holds 10
                                  events in both files (an avalanche-prone member has many
                                  large events: events are not independent draws). Files
                                  without the per-member counts (`events/member_*`) are
                                  compared as if the events were independent: the standard
                                  error of the pooled mean, and a two-sample chi2 test of the
                                  pooled counts (bins merged from the top until each holds 5
                                  expected events).

With --paired the two files hold the same members (one scan seed, the same points and seeds; a
file of some of them, `--finished-only` or a shard's, pairs its members with the same seeds),
each started from the same drops, so a member's two results are correlated and the combined
errors above too large. nu_lower_half, mean abs(Delta y) (from the members' own values, in files
from 2026-11-28 on), in protocol C nu_i and dnu/nu_i (each member's nu_lower_half / nu_i - 1, in
files from 2026-12-05 on) and the profile fits (through the bins both files' members fill) are
then compared member by member: the standard error of the members' differences, and the
jackknife of the fits' difference (the same member left out of both files), over the members
that finished in both. The other quantities, distributions, stay as above. A point with fewer
than 4 members finished in both is compared unpaired, and says so.

A strip's or bin's difference over its combined standard error, each error from the scatter
of few members, follows Student's t (Welch's degrees of freedom), whose tails are heavier than
a normal's: summed as it is, a chi2 over ten bins of 4 members a file rejects equal ensembles
about 17 % of the time at its 99 % bound. Each such t enters the chi2 as the normal deviate of
the same tail probability, which rejects them about 1 % of the time (2-3 % when one file has
four times the other's members).

The strips and bins are summed as independent, but neighbouring ones move together through the
members (a member that moved more did so over a range of heights; a disk spans neighbouring
strips), so such a chi2 exceeds its own 99 % quantile for equal ensembles more often than 1 %
(about 5 % in test_compare.py's ensembles of 8 members whose bins move together). Its bound is
therefore the 99 % quantile of the same chi2 over 1 999 random splits of the two files' members
(all of them where there are fewer) into groups of their sizes (scipy.stats.permutation_test,
seeded, so a comparison is reproducible): whole members move, so every correlation between the
bins goes with them, and equal ensembles cross it about once in a hundred. Where the members
allow fewer than 200 distinct splits (4 and 4 members: 70) the bound is the nominal one, 99 %
of chi2 (for nu(y) three times that of a third of its strips' degrees of freedom), which marks
equal ensembles more often than 1 % where neighbouring bins move together strongly, and the row
does not say "bound from splits of the members". So are nu(y) rows of files without per-member
rows (`nu/member_mean`).

Points pair up by their parameters (protocol, Bond number, box, capture radius, disk and contact
parameters, time step). Where some have no counterpart of the same parameters and the two files hold
the same point indices (two runs of one scan's points with a setting changed, such as the time
step), the index pairs them, and the parameters they differ in are named. Points of different
protocols are not compared (exit 2). A scalar without an error (a point with one finished member) is
not judged, nor is a quantity one file holds and the other lacks (its row says which), nor the mean
size of the avalanche events where a side's events all lie in one bin of sizes or come from one
member (no error), nor the histogram's shape where a side has fewer than 4 members with disks (its
verdict rests on Poisson's errors), nor mean abs(Delta y) and the profile fits where in both files
the disks moved less than `event_threshold` on average (round-off). A scalar differs when its
distance exceeds --sigma (2) combined standard errors; a profile or histogram when its chi2 exceeds
the bound; the shapes when no shape fits both and a verdict is one. With n scalars compared at 2
sigma, about n/20 differ by chance, and more where the errors come from few members (about 9 % of
them with 4 members, 6.5 % with 8: an error estimated from few members is itself uncertain). Exits
with 1 when anything differs, 2 on unusable input.
--json appends one JSON line per point (a scalar's values and errors also as numbers, `a_value`,
`a_error`, `b_value`, `b_error`, and with --paired the members' difference B - A and its error,
`paired_difference`, `paired_error`). Uses Debian's python3-h5py, python3-numpy and python3-scipy.
"""
import argparse
import json
import math
import os
import sys
import warnings

try:
    import h5py
    import numpy as np
    from scipy import stats
except ImportError as e:  # pragma: no cover
    sys.exit(f"compare.py: {e}; install python3-h5py and python3-scipy (scripts/install-deps.sh)")

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from claims import (Profile, attribute_value, check_result_file, chi2_quantile99,  # noqa: E402
                    jackknife, moved, text)


class Row:
    """One quantity of one point in both files: a value and error each, or a test's statistic."""

    def __init__(self, name, a, b, distance, bound, detail="", values=None, paired=None):
        self.name, self.a, self.b = name, a, b
        self.distance, self.bound, self.detail = distance, bound, detail
        self.values = values  # (a, error of a, b, error of b) as numbers, for a scalar
        self.paired = paired  # (B - A, its error) of the members' paired difference

    @property
    def judged(self):
        """False where a value or its error is not a number (one member, or none finished)."""
        return not math.isnan(self.distance)

    @property
    def within(self):
        return not self.judged or self.distance <= self.bound

    def record(self):
        record = {"quantity": self.name, "a": self.a, "b": self.b,
                  "distance": self.distance if self.judged else None, "bound": self.bound,
                  "within": bool(self.within) if self.judged else None, "detail": self.detail}
        if self.values is not None:
            number = lambda v: float(v) if math.isfinite(v) else None
            for key, v in zip(("a_value", "a_error", "b_value", "b_error"), self.values):
                record[key] = number(v)
            if self.paired is None and (q := ratio(*self.values)):
                record["ratio"], record["ratio_error"] = map(number, q)
        if self.paired is not None:
            record["paired_difference"], record["paired_error"] = map(number, self.paired)
        return record


def value(v, e):
    return f"{v:.4g} +- {e:.2g}"


def ratio(a, ea, b, eb):
    """A / B and its standard error to first order, the two estimates independent; None where B
    is not resolved from 0 (within two of its errors: a ratio whose first-order error means
    nothing, as for a profile's constant a near 0) or A is 0 (no relative error)."""
    if a == 0 or not abs(b) > 2 * eb:
        return None
    q = a / b
    return q, abs(q) * math.hypot(ea / a, eb / b)


def scalar(name, a, ea, b, eb, sigma):
    """Two estimates with standard errors: their distance in combined standard errors, and A / B
    (how a width or a setting scales a quantity, as docs/REPRODUCTION.md quotes it)."""
    combined = math.hypot(ea, eb)
    if math.isnan(a) or math.isnan(b) or math.isnan(combined):
        return Row(name, value(a, ea), value(b, eb), math.nan, sigma,
                   "not judged (no value or no error: fewer than two members finished)",
                   (a, ea, b, eb))
    z = abs(b - a) / combined if combined > 0 else (0.0 if a == b else math.inf)
    detail = f"{z:.2f} sigma"
    if q := ratio(a, ea, b, eb):
        detail += f"; A/B {q[0]:#.3g} +- {q[1]:.2g}"
    return Row(name, value(a, ea), value(b, eb), z, sigma, detail, (a, ea, b, eb))


def one_sided(name, in_a, in_b):
    """A not-judged row for a quantity one file holds and the other lacks (a damaged or edited
    file, or one of an older program), so that it does not drop out of the comparison unseen;
    None when both hold it or neither does."""
    if in_a == in_b:
        return None
    return Row(name, "-" if not in_a else "present", "-" if not in_b else "present", math.nan,
               0.0, f"not judged (absent from {'A' if not in_a else 'B'})")


def welch_as_normal(difference, var_a, n_a, var_b, n_b):
    """Each difference over its combined standard error sqrt(var_a + var_b) (the variances of
    two means over n_a and n_b members) as a normal deviate: the one of the same tail
    probability as Student's t with Welch-Satterthwaite's degrees of freedom."""
    combined = var_a + var_b
    t = difference / np.sqrt(combined)
    with np.errstate(divide="ignore", invalid="ignore"):
        dof = combined ** 2 / (var_a ** 2 / (n_a - 1) + var_b ** 2 / (n_b - 1))
    dof = np.where(np.isfinite(dof), dof, np.inf)
    return np.sign(t) * stats.norm.isf(stats.t.sf(np.abs(t), dof))


PERMUTATIONS = 1999  # random splits of the members (all of them where there are fewer)
LEAST_SPLITS = 200  # fewer distinct splits leave the bound's 99 % quantile to a handful


def permuted_bound(statistic, rows_a, rows_b):
    """The 99 % quantile of `statistic`(rows of A, rows of B) over splits of the two files'
    members (rows) into groups of their sizes (scipy.stats.permutation_test; `statistic` takes
    stacks of splits, [..., members, bins], and reduces over the members' axis): the statistic's
    distribution where the two ensembles are alike, whatever the correlation between its bins,
    since whole members move. NaN where the members allow fewer than LEAST_SPLITS distinct
    splits (4 and 4 members: 70)."""
    n_a, n = len(rows_a), len(rows_a) + len(rows_b)
    if math.comb(n, n_a) < LEAST_SPLITS:
        return math.nan
    pooled = np.concatenate([rows_a, rows_b])
    split = lambda ia, ib, axis: statistic(pooled[ia.astype(int)], pooled[ib.astype(int)])
    res = stats.permutation_test((np.arange(n_a), np.arange(n_a, n)), split, vectorized=True,
                                 n_resamples=PERMUTATIONS, batch=250, alternative="greater",
                                 random_state=0)
    return float(np.quantile(res.null_distribution, 0.99, method="higher"))


def chi2_row(name, a, b, chi2, dof, bound, detail):
    return Row(name, a, b, chi2, bound, f"chi2 {chi2:.1f} for {dof} (bound {bound:.1f}){detail}")


def paired_row(name, a, ea, b, eb, difference, error, sigma):
    """Each file's value and error as stored, and their distance in standard errors of the
    members' paired difference."""
    z = abs(difference) / error if error > 0 else (0.0 if difference == 0 else math.inf)
    return Row(name, value(a, ea), value(b, eb), z, sigma, f"{z:.2f} sigma (paired)",
               (a, ea, b, eb), (difference, error))


# The fewest members finished in both files that a paired comparison takes (the jackknife of a
# profile fit's difference needs a few); a point with fewer is compared unpaired, and says so.
PAIRED_MEMBERS = 4


def members_in_both(pa, pb):
    """The members that finished in both points, when the files are of one scan seed (so that a
    seed index is the same member in both; a file of some members, `--finished-only` or a shard,
    holds some of them): a mask over each point's members, (in A, in B), selecting the same seeds
    in the same order; else None and why not."""
    fa, fb = pa.file.attrs, pb.file.attrs
    if fa.get("seed") != fb.get("seed") or fa.get("seeds") != fb.get("seeds"):
        return None, "the files' scan seeds or seed counts differ"
    for point, which in ((pa, "A"), (pb, "B")):
        if not all(f"members/{k}" in point for k in ("seed_index", "failure")):
            return None, f"{which} holds no per-member datasets (members/seed_index, failure)"
    ia, ib = pa["members/seed_index"][()], pb["members/seed_index"][()]
    finished = set(ia[pa["members/failure"][()] == 0]) & set(ib[pb["members/failure"][()] == 0])
    ok_a, ok_b = np.isin(ia, list(finished)), np.isin(ib, list(finished))
    if not np.array_equal(ia[ok_a], ib[ok_b]):
        return None, "the points hold their members in another order"
    if len(finished) < PAIRED_MEMBERS:
        return None, f"fewer than {PAIRED_MEMBERS} members finished in both"
    return (ok_a, ok_b), ""


def member_values(point, key):
    """The point's members' own values of `key` (members/KEY; dnu/nu_i, which has none stored,
    from each member's nu_lower_half / nu_i - 1, as the program's mean), or None."""
    if key == "relative_increase":
        if not all(f"members/{k}" in point for k in ("nu_lower_half", "nu_initial")):
            return None
        with np.errstate(divide="ignore", invalid="ignore"):
            return point["members/nu_lower_half"][()] / point["members/nu_initial"][()] - 1.0
    return point[f"members/{key}"][()] if f"members/{key}" in point else None


def point_scalars(pa, pb, sigma, both=None):
    for key, name in (("nu_lower_half", "nu_lower_half"), ("mean_abs_dy", "mean abs(Delta y) [R]"),
                      ("nu_initial", "nu_i"), ("relative_increase", "dnu/nu_i")):
        if key in ("nu_initial", "relative_increase") and text(pa.attrs.get("protocol", "")) != "C":
            continue  # protocol C's
        if f"{key}_mean" not in pa.attrs or f"{key}_mean" not in pb.attrs:
            if row := one_sided(name, f"{key}_mean" in pa.attrs, f"{key}_mean" in pb.attrs):
                yield row
            continue
        a, ea = float(pa.attrs[f"{key}_mean"]), float(pa.attrs[f"{key}_sem"])
        b, eb = float(pb.attrs[f"{key}_mean"]), float(pb.attrs[f"{key}_sem"])
        va, vb = member_values(pa, key), member_values(pb, key)
        if both is not None and va is not None and vb is not None:
            # A finished member without a value (a band its collapse left empty) pairs with
            # nothing, as the means leave it out.
            d = vb[both[1]] - va[both[0]]
            d = d[np.isfinite(d)]
            if len(d) < 2:
                yield Row(name, value(a, ea), value(b, eb), math.nan, sigma,
                          "not judged (fewer than two members with a value in both)",
                          (a, ea, b, eb))
            else:
                yield paired_row(name, a, ea, b, eb, d.mean(),
                                 d.std(ddof=1) / math.sqrt(len(d)), sigma)
        else:
            yield scalar(name, a, ea, b, eb, sigma)


def paired_fit_difference(pa, pb, key, degree, both):
    """The difference B - A of the profile fit's coefficients, each through the bins that every
    member of both ensembles fills (where the two files bin alike; else each through its own,
    as the program fits), and its jackknife error with the same member left out of both."""
    prof_a = Profile(pa[key], -math.inf, math.inf, both[0])
    prof_b = Profile(pb[key], -math.inf, math.inf, both[1])
    if np.array_equal(pa[key]["centre"][()], pb[key]["centre"][()]):
        common = prof_a.use & prof_b.use
        prof_a = Profile(pa[key], -math.inf, math.inf, both[0], common)
        prof_b = Profile(pb[key], -math.inf, math.inf, both[1], common)
    fit = lambda prof, m=None: np.polynomial.polynomial.polyfit(*prof.pooled(m), degree)
    full = fit(prof_b) - fit(prof_a)
    loo = [fit(prof_b, m) - fit(prof_a, m) for m in range(prof_a.members)]
    return full, jackknife(loo)


def profile_fits(pa, pb, sigma, both=None):
    """a, b, c of the avalanche profile against y_i and y_e (protocol A), or the line's a, b."""
    for by in ("yi", "ye"):
        key = f"avalanche_by_{by}"
        path = f"{key}/fit"
        if path not in pa or path not in pb:
            if row := one_sided(f"Delta y({'y_i' if by == 'yi' else 'y_e'}): fit", path in pa,
                                path in pb):
                yield row
            continue
        fa, fb = pa[path], pb[path]
        if not (fa.attrs.get("valid", 1) and fb.attrs.get("valid", 1)):
            continue
        ca, ea, cb, eb = fa["coef"][()], fa["error"][()], fb["coef"][()], fb["error"][()]
        name = lambda k: f"Delta y({'y_i' if by == 'yi' else 'y_e'}): {'abc'[k]}"
        if (both is not None and len(ca) == len(cb) and "member_mean" in pa[key]
                and "member_mean" in pb[key]):
            difference, error = paired_fit_difference(pa, pb, key, len(ca) - 1, both)
            for k in range(len(ca)):
                yield paired_row(name(k), ca[k], ea[k], cb[k], eb[k], difference[k], error[k],
                                 sigma)
            continue
        for k in range(min(len(ca), len(cb))):
            yield scalar(name(k), ca[k], ea[k], cb[k], eb[k], sigma)


def density_profile(pa, pb):
    """nu(y) strip by strip where both ensembles have two or more members in the strip; where both
    files keep the members' rows, chi2 from them and its bound from splits of the members
    (permuted_bound), else from the files' means and standard errors."""
    na, nb = pa["nu"], pb["nu"]
    strips = min(len(na["mean"]), len(nb["mean"]))
    ma, mb = na["mean"][:strips], nb["mean"][:strips]
    sa, sb = na["sem"][:strips], nb["sem"][:strips]
    ca, cb = na["members"][:strips], nb["members"][:strips]
    use = (ca >= 2) & (cb >= 2) & (np.hypot(sa, sb) > 0)
    if use.sum() < 3:
        return
    z = welch_as_normal(mb[use] - ma[use], sa[use] ** 2, ca[use], sb[use] ** 2, cb[use])
    dof = int(use.sum())
    chi2 = float((z ** 2).sum())
    bound, how = math.nan, ""
    if "member_mean" in na and "member_mean" in nb:
        rows = lambda g: g["member_mean"][()][:, :strips]
        ra, rb = rows(na), rows(nb)
        ra, rb = ra[np.isfinite(ra).any(axis=1)], rb[np.isfinite(rb).any(axis=1)]  # failed: NaN

        def statistic(x, y):  # [..., members, strips]
            def mean_var(r):
                r = r[..., use]
                return (np.nanmean(r, axis=-2), np.nanvar(r, axis=-2, ddof=1),
                        np.isfinite(r).sum(axis=-2))
            (mx, vx, nx), (my, vy, ny) = mean_var(x), mean_var(y)
            t = welch_as_normal(my - mx, vx / nx, nx, vy / ny, ny)
            return np.nansum(t ** 2, axis=-1)

        with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a strip one split leaves empty
            bound = permuted_bound(statistic, ra, rb)
            chi2 = float(statistic(ra, rb))  # the same statistic as the splits', from the rows
        how = ", bound from splits of the members"
    if math.isnan(bound):  # a disk spans neighbouring strips: a third of the strips' freedom
        bound, how = 3 * chi2_quantile99(max(dof / 3, 1)), ", bound 3 chi2_99(strips/3)"
    yield chi2_row("nu(y)", f"{ma[use].mean():.4f} (strip mean)", f"{mb[use].mean():.4f}",
                   chi2, dof, bound, f", largest abs(z) {np.abs(z).max():.2f}{how}")


def member_fractions(rows, bins):
    """Each member's share of its counts per bin, over `bins` bins (a histogram's bins reach its
    largest abs(Delta y), so two files may have different numbers; the missing ones are 0), and
    the counts per bin; members without counts (failed) are left out."""
    rows = rows.astype(float)
    rows = rows[rows.sum(axis=1) > 0]
    rows = np.pad(rows, ((0, 0), (0, bins - rows.shape[1])))
    return rows / rows.sum(axis=1, keepdims=True), rows.sum(axis=0)


def fractions(name, rows_a, rows_b, bins, unit):
    """Rows (none or one) comparing the members' fractions per bin of two files: mean and
    standard error over each file's members, chi2 over the bins with 10 counts or more in both
    (all but one where that is every bin), its bound from splits of the members (permuted_bound;
    the 99 % quantile of chi2 where the members allow too few)."""
    (fa, ta), (fb, tb) = member_fractions(rows_a, bins), member_fractions(rows_b, bins)
    if len(fa) < 2 or len(fb) < 2:
        return
    use = (ta >= 10) & (tb >= 10)
    va, vb = fa.var(axis=0, ddof=1) / len(fa), fb.var(axis=0, ddof=1) / len(fb)
    use &= va + vb > 0
    if use.all():  # each member's fractions add up to one: the last bin follows from the others
        use[-1] = False
    if use.sum() < 1:
        return

    def statistic(x, y):  # [..., members, bins]
        x, y, n_x, n_y = x[..., use], y[..., use], x.shape[-2], y.shape[-2]
        z = welch_as_normal(y.mean(axis=-2) - x.mean(axis=-2), x.var(axis=-2, ddof=1) / n_x, n_x,
                            y.var(axis=-2, ddof=1) / n_y, n_y)
        return np.nansum(z ** 2, axis=-1)  # a bin no member of a split fills: no term

    dof, chi2 = int(use.sum()), float(statistic(fa, fb))
    with np.errstate(invalid="ignore", divide="ignore"):
        bound = permuted_bound(statistic, fa, fb)
    how = ", bound from splits of the members"
    if math.isnan(bound):
        bound, how = chi2_quantile99(dof), ""
    z = welch_as_normal(fb.mean(axis=0)[use] - fa.mean(axis=0)[use], va[use], len(fa), vb[use],
                        len(fb))
    yield chi2_row(name, f"{int(ta.sum())} {unit}", f"{int(tb.sum())} {unit}", chi2, dof, bound,
                   f", largest abs(z) {np.abs(z).max():.2f}{how}")


def acceptable(group, shape):
    """Whether the histogram's fit of `shape` is acceptable as the program judges it (attribute
    `acceptable`: its next two terms within their bounds, or where the members give no errors
    Pearson's chi2 within its 99 % quantile); in files before 2026-12-03, its chi2 within the
    99 % quantile."""
    if shape not in group:
        return False
    a = group[shape].attrs
    if "acceptable" in a:
        return bool(a["acceptable"])
    return bool(a.get("valid", 0)) and float(a["chi2"]) <= chi2_quantile99(max(float(a["dof"]), 1))


def histogram(pa, pb):
    """The cut histograms: one shape must fit both (or neither file's verdict be a shape), and
    the members' fractions per bin must agree."""
    ha, hb = pa.get("abs_dy_histogram"), pb.get("abs_dy_histogram")
    if ha is None or hb is None:
        if row := one_sided("abs(Delta y) histogram", ha is not None, hb is not None):
            yield row
        return
    sa, sb = ha["shape_cut"], hb["shape_cut"]
    va, vb = text(sa.attrs["preferred"]), text(sb.attrs["preferred"])
    fits = [v for v in ("gaussian", "exponential") if acceptable(sa, v) and acceptable(sb, v)]
    same = bool(fits) or (va == vb and va not in ("gaussian", "exponential"))
    # No errors from the members' scatter (fewer than 4 members with disks): the program's
    # verdict rests on Poisson's errors, far too small for counts that move together (as
    # claims.py, which judges no shape by them).
    poisson = [w for w, h, sh in (("A", ha, sa), ("B", hb, sb))
               if "member_counts_cut" in h and not sh.attrs.get("member_errors", 0)]
    if not fits and "none" in (va, vb):  # a histogram of too few bins for a shape fit
        yield Row("abs(Delta y) histogram (cut): shape", va, vb, math.nan, 0.0,
                  "not judged (too few bins to fit a shape)")
    elif poisson:
        yield Row("abs(Delta y) histogram (cut): shape", va, vb, math.nan, 0.0,
                  f"not judged ({' and '.join(poisson)}: no errors from the members' scatter to "
                  "judge a shape by, its verdict on Poisson's)")
    else:
        yield Row("abs(Delta y) histogram (cut): shape", va, vb, 0.0 if same else 1.0, 0.0,
                  f"{' and '.join(fits)} fit{'s' if len(fits) == 1 else ''} both" if fits else
                  ("neither fits either" if same else "no shape fits both"))
    if "member_counts_cut" not in ha or "member_counts_cut" not in hb:
        return
    ea, eb = ha["edges"][()], hb["edges"][()]
    bins = max(len(ea), len(eb)) - 1
    common = min(len(ea), len(eb))
    if not np.array_equal(ea[:common], eb[:common]):
        return  # bins of different widths: not comparable bin by bin
    yield from fractions("abs(Delta y) histogram (cut): fractions", ha["member_counts_cut"][()],
                         hb["member_counts_cut"][()], bins, "disks")


def mean_log(edges, counts, member_rows=None):
    """Mean of log10 of the binned values (bins' geometric centres), and its standard error: a
    jackknife over the members where their rows are given, else that of independent values."""
    centre = 0.5 * (np.log10(edges[1:]) + np.log10(edges[:-1]))
    n = counts.sum()
    if n < 2:
        return math.nan, math.nan
    m = (counts * centre).sum() / n
    if member_rows is not None:
        rows = member_rows[member_rows.sum(axis=1) > 0]
        if len(rows) < 2:  # one member's events: no scatter over members to take an error from
            return m, math.nan
        rest = rows.sum(axis=0) - rows  # each member left out in turn
        loo = (rest * centre).sum(axis=1) / rest.sum(axis=1)
        return m, float(jackknife(loo))
    var = (counts * (centre - m) ** 2).sum() / (n - 1)
    return m, math.sqrt(var / n)


def merged_from_the_top(rows_a, rows_b, least=10):
    """Two files' per-member counts with their bins merged from the top until each merged bin
    holds `least` counts in both files (what is left at the bottom joins the last one)."""
    ta, tb = rows_a.sum(axis=0), rows_b.sum(axis=0)
    groups, current = [], []
    for j in range(len(ta) - 1, -1, -1):
        current.append(j)
        if ta[current].sum() >= least and tb[current].sum() >= least:
            groups.append(current)
            current = []
    if current and groups:
        groups[-1] += current
    merge = lambda rows: np.stack([rows[:, g].sum(axis=1) for g in groups], axis=1)
    return (merge(rows_a), merge(rows_b)) if groups else (rows_a, rows_b)


def homogeneity(ca, cb):
    """Two-sample chi2 of two binned samples: (chi2, dof), bins merged from the top until every
    bin expects 5 events from each sample."""
    na, nb = ca.sum(), cb.sum()
    if na == 0 or nb == 0:
        return math.nan, 0
    merged, acc = [], np.zeros(2)
    for x, y in zip(ca[::-1], cb[::-1]):
        acc += (x, y)
        total = acc.sum()
        if total * na / (na + nb) >= 5 and total * nb / (na + nb) >= 5:
            merged.append(acc.copy())
            acc[:] = 0
    if acc.sum() > 0 and merged:
        merged[-1] += acc
    if len(merged) < 2:
        return math.nan, 0
    m = np.array(merged)
    expected = np.outer(m.sum(axis=1), (na, nb)) / (na + nb)
    return float(((m - expected) ** 2 / expected).sum()), len(m) - 1


def events(pa, pb, sigma):
    """The avalanche events: the mean log size, and the distributions of sizes and of steps, by
    the members' scatter where both files keep per-member counts, else as independent events."""
    ea, eb = pa.get("events"), pb.get("events")
    held = lambda e: e is not None and "moved_counts" in e
    if not (held(ea) and held(eb)):
        if row := one_sided("avalanche events", held(ea), held(eb)):
            yield row
        return
    per_member = "member_moved_counts" in ea and "member_moved_counts" in eb
    rows = lambda e, key: e["member_" + key][()].astype(float) if per_member else None
    edges = ea["edges"][()]
    ma, se_a = mean_log(edges, ea["moved_counts"][()], rows(ea, "moved_counts"))
    mb, se_b = mean_log(edges, eb["moved_counts"][()], rows(eb, "moved_counts"))
    name = "events: mean log10(disks moved)"
    if math.isfinite(ma) and math.isfinite(mb):
        if math.isnan(se_a) or math.isnan(se_b):
            yield Row(name, value(ma, se_a), value(mb, se_b), math.nan, sigma,
                      "not judged (a side's events from one member: no error from their scatter)",
                      (ma, se_a, mb, se_b))
        elif se_a > 0 and se_b > 0:
            yield scalar(name, ma, se_a, mb, se_b, sigma)
        else:  # every event of a side in one bin: its error from the bins' centres is no error
            yield Row(name, value(ma, se_a), value(mb, se_b), math.nan, sigma,
                      "not judged (a side's events all in one bin of sizes: no error)",
                      (ma, se_a, mb, se_b))
    for key, name in (("moved_counts", "disks moved"), ("steps_counts", "steps")):
        if per_member:
            a, b = merged_from_the_top(rows(ea, key), rows(eb, key))
            yield from fractions(f"events: distribution of {name}", a, b, a.shape[1], "events")
        elif key in ea and key in eb:
            ca, cb = ea[key][()].astype(float), eb[key][()].astype(float)
            chi2, dof = homogeneity(ca, cb)
            if dof > 0:
                yield chi2_row(f"events: distribution of {name}", f"{int(ca.sum())} events",
                               f"{int(cb.sum())} events", chi2, dof, chi2_quantile99(dof), "")


def compare_point(pa, pb, sigma, both=None):
    """The rows of one point; `both` (members_in_both) compares its members in pairs."""
    rows = list(point_scalars(pa, pb, sigma, both))
    if "nu" in pa and "nu" in pb:
        rows += density_profile(pa, pb)
    elif row := one_sided("nu(y)", "nu" in pa, "nu" in pb):
        rows.append(row)
    rows += profile_fits(pa, pb, sigma, both)
    rows += histogram(pa, pb)
    rows += events(pa, pb, sigma)
    if not moved(pa) and not moved(pb):
        # Disks that moved less than event_threshold on average in both files: the sizes of
        # the moves and the profile's lines are round-off's (as the program's fits across points
        # and claims.py leave them), whatever their distance.
        for r in rows:
            if r.name.startswith(("mean abs(Delta y)", "Delta y(")) and r.judged:
                r.distance = math.nan
                r.detail = "not judged (nothing moved beyond event_threshold in either file)"
    return rows


def describe(point):
    a = point.attrs
    keys = ("protocol", "bond_number", "width", "height", "capture_radius", "members")
    return ", ".join(f"{k} {text(a[k]) if isinstance(a[k], (bytes, str)) else f'{a[k]:g}'}"
                     for k in keys if k in a)


POINT_KEYS = ("protocol", "bond_number", "width", "height", "capture_radius", "radius",
              "polydispersity", "cohesion_range", "friction", "rolling_friction", "time_step",
              "disk_density", "gravity", "floor_cohesion")


# What defines the observables rather than the physics: the bands of point attributes, and the
# strips, bins, stop rule and event threshold of the files' settings.
DEFINITION_KEYS = ("lower_half_from", "cut_bottom", "cut_top")
DEFINITION_SETTINGS = ("strip_width", "bin_width", "abs_dy_bin", "stop_rule", "event_threshold")


def definitions_differ(pa, pb):
    """The definitions of observables two paired points' files differ in: a note, since a
    quantity defined differently differs whatever the physics."""
    sa, sb = (p.file["settings"].attrs if "settings" in p.file else {} for p in (pa, pb))
    differ = lambda a, b, k: k in a and k in b and attribute_value(a[k]) != attribute_value(b[k])
    return ([k for k in DEFINITION_KEYS if differ(pa.attrs, pb.attrs, k)] +
            [k for k in DEFINITION_SETTINGS if differ(sa, sb, k)])


def scan_keys_differ(pa, pb):
    """The scan parameters two paired points differ in (the point index pairs them): a note, so
    that a comparison of unlike points is seen as one. A parameter one point lacks differs too:
    two points pair by their parameters only where both say them."""
    differ = []
    for k in POINT_KEYS:
        if k in pa.attrs and k in pb.attrs:
            if attribute_value(pa.attrs[k]) != attribute_value(pb.attrs[k]):
                differ.append(k)
        elif k in pa.attrs or k in pb.attrs:
            differ.append(f"{k} (absent from {'B' if k in pa.attrs else 'A'})")
    return differ


def pair_points(fa, fb):
    """The pairs (name in A, name in B) to compare, and a note on how they were paired.

    Points of the same parameters pair up. Where that pairs every point of both files, those are
    the pairs; else, where the two files have the same point names (two runs of one scan's
    points with a setting changed: a time step, another program version), the index pairs them;
    else only the points of the same parameters are compared."""
    names_a, names_b = sorted(fa["points"]), sorted(fb["points"])
    free = list(names_b)
    by_parameters = []
    for a in names_a:
        b = next((b for b in free if not scan_keys_differ(fa["points"][a], fb["points"][b])), None)
        if b is not None:
            free.remove(b)
            by_parameters.append((a, b))
    if len(by_parameters) == len(names_a) == len(names_b):
        return by_parameters, "by their parameters"
    if names_a == names_b:
        return [(n, n) for n in names_a], "by their index"
    return by_parameters, "by their parameters (the files hold other points)"


def positive(value):
    v = float(value)
    if not v > 0:
        raise argparse.ArgumentTypeError(
            f"must be a positive number of standard errors, not {value}")
    return v


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("a", help="a result file of `loosepack run`")
    ap.add_argument("b", help="the other result file")
    ap.add_argument("--sigma", type=positive, default=2.0,
                    help="a scalar differs beyond this many combined standard errors (default 2)")
    ap.add_argument("--json", help="append one JSON line per point to this file")
    ap.add_argument("--label", default="", help="a note stored with each JSON line")
    ap.add_argument("--paired", action="store_true",
                    help="the files hold the same members (one scan seed): compare nu_lower_half, "
                         "mean abs(Delta y) and the profile fits member by member")
    args = ap.parse_args()
    if args.json and not os.path.isdir(os.path.dirname(args.json) or "."):
        print(f"compare.py: --json {args.json}: its directory does not exist", file=sys.stderr)
        sys.exit(2)
    differ = not_judged = 0
    try:
        fa, fb = h5py.File(args.a, "r"), h5py.File(args.b, "r")
    except OSError as e:
        print(f"compare.py: {e}", file=sys.stderr)
        sys.exit(2)
    with fa, fb:
        check_result_file(fa, args.a, "compare.py")
        check_result_file(fb, args.b, "compare.py")
        points_a, points_b = fa["points"], fb["points"]
        pairs, how = pair_points(fa, fb)
        if not pairs:
            print(f"compare.py: {args.a} and {args.b} share no scan point of the same parameters "
                  f"({', '.join(POINT_KEYS)}), nor the same points", file=sys.stderr)
            sys.exit(2)
        for path, names, taken in ((args.a, points_a, {a for a, _ in pairs}),
                                   (args.b, points_b, {b for _, b in pairs})):
            if only := sorted(set(names) - taken):
                print(f"compare.py: the points {', '.join(only)} of {path} have no counterpart "
                      "of the same parameters in the other file: not compared", file=sys.stderr)
        # Every point compared before anything is printed or appended to --json: a point the
        # comparison refuses leaves neither half written.
        compared = []
        for name_a, name_b in pairs:
            pa, pb = points_a[name_a], points_b[name_b]
            name = name_a if name_a == name_b else f"{name_a} / {name_b}"
            if text(pa.attrs.get("protocol", "")) != text(pb.attrs.get("protocol", "")):
                print(f"compare.py: point {name} is of protocol {text(pa.attrs.get('protocol'))} "
                      f"in {args.a} and {text(pb.attrs.get('protocol'))} in {args.b}: runs of "
                      "different protocols are not comparable", file=sys.stderr)
                sys.exit(2)
            both, unpaired = None, ""
            if args.paired:
                both, why = members_in_both(pa, pb)
                if both is None and why.startswith("fewer than"):
                    unpaired = f"; {why}: compared unpaired"
                    print(f"compare.py: --paired: point {name}: {why}: compared unpaired",
                          file=sys.stderr)
                elif both is None:
                    print(f"compare.py: --paired: point {name} of {args.a} and {args.b}: {why}",
                          file=sys.stderr)
                    sys.exit(2)
            try:
                rows = compare_point(pa, pb, args.sigma, both)
            except KeyError as e:
                print(f"compare.py: point {name}: a dataset the comparison reads is missing from "
                      f"{args.a} or {args.b} ({e}): a damaged file, or one not written by "
                      "`loosepack run`", file=sys.stderr)
                sys.exit(2)
            compared.append((name, pa, pb, unpaired, rows))
        for name, pa, pb, unpaired, rows in compared:
            print(f"\npoint {name}: A {describe(pa)}; B {describe(pb)} (paired {how}{unpaired})\n")
            if differing := scan_keys_differ(pa, pb):
                print(f"(the two points differ in {', '.join(differing)})\n")
            if defined := definitions_differ(pa, pb):
                print(f"(the files define observables differently: {', '.join(defined)}; what "
                      "depends on them differs whatever the physics)\n")
            print("| quantity | A | B | distance | within |")
            print("|---|---|---|---|---|")
            for r in rows:
                verdict = "yes" if r.within else "NO"
                print(f"| {r.name} | {r.a} | {r.b} | {r.detail} | "
                      f"{verdict if r.judged else '-'} |")
            differ += sum(not r.within for r in rows)
            not_judged += sum(not r.judged for r in rows)
            if args.json:
                with open(args.json, "a") as out:
                    out.write(json.dumps({"a": args.a, "b": args.b, "point": name,
                                          "label": args.label, "a_point": describe(pa),
                                          "b_point": describe(pb),
                                          "rows": [r.record() for r in rows]}) + "\n")
    print(f"\n{differ} quantit{'y differs' if differ == 1 else 'ies differ'} beyond the bounds"
          + (f"; {not_judged} not judged" if not_judged else ""))
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()
