#!/usr/bin/env python3
"""Checks the paper's qualitative claims on a loosepack result file and says which hold.

    /usr/bin/python3 tools/claims.py out/claims.h5

For every scan point it can judge (from the fits the program stored, docs/OUTPUT.md):

  A, 0 < Bo < inf   the avalanche profile Delta y(y_e) is a parabola with positive curvature
                    (paper figs. 6, 7, 11): fitted to the bins between the bottom and top cuts
                    (`cut_bottom`, `cut_top`), the parabola is acceptable (its cubic term within
                    the 99 % bound, below), its curvature c2 > 0 beyond that bound (which rejects
                    the straight line, and with it the constant), and its vertex lies inside
                    the band
  A, Bo = 0         no parabola: in the same band a constant Delta y is acceptable (the paper:
                    about 1.5 R at every height: neither the line's slope nor the parabola's
                    curvature beyond its 99.5 % bound, both together 1 %) and the parabola claim
                    fails
  A, Bo = 0         the |Delta y| histogram is exponential (fig. 9)
  A, Bo = 1e3       the |Delta y| histogram is Gaussian (fig. 8; the paper says it of Bo = 1e3,
                    not of larger Bond numbers): the program's verdict (`preferred`), which
                    needs the lower information criterion and an acceptable shape (its next two
                    terms within their bounds, errors from the members' scatter; docs/OUTPUT.md,
                    "Analysis")
  A, Bo = 1e3       the cut histogram's skew is that of its height slices' Gaussians summed:
                    in each member, the disks of each bin of Delta y(y_e) within the cut taken
                    as normal about the member's mean there, with the bin's spread within
                    members, |Delta y| folded at 0; the cubic term of the histogram's fit the
                    sum's within the two-sided 99 % bound of their difference's t (jackknife over
                    the members, each left out of both). The profile's means spread over the cut
                    make such a sum skewed, and a single Gaussian fails where that skew is
                    resolved (the quadratic and quartic terms are shown, not judged: the slices'
                    own tails are heavier than a Gaussian's)
  A, 0 < Bo < 1e4   (with `observables.trajectory_every`, 4 or more members) the avalanches
                    move disks collectively and mainly downwards (fig. 5): over the sampled
                    disks' paths after their own deposition, the mean downward displacement
                    exceeds the mean sideways one beyond t95 (below); and neighbours (centres
                    within 3 R when the later one lands) move together: the cosine between two
                    disks' paths (their displacements at every later deposition as one vector)
                    is larger for neighbours than for disks at the same height (within 3 R) at
                    least 12 R apart sideways, beyond t95 (jackknife over members)
  C                 Delta y is a straight line in y_e and in y_i (each line acceptable: its
                    quadratic term within the 99.5 % bound), and the coefficient identity
                    b' = b/(1+b), a' = a/(1+b) holds: each difference within t95 of zero, its
                    error a jackknife of the difference itself (figs. 14, 15)

  A, Bo = 0         beyond 2 R the cut histogram decays exponentially (the slope negative
                    beyond t95 of its jackknife error, the quadratic and cubic terms within
                    their bounds),
                    and between 1 and 2 R its probability is about constant (one constant
                    acceptable through those bins): the paper's "exponential decay" with its
                    stated deviation (fig. 9)
  A, Bo = 1e2, 1e3  (H >= 220, the paper's width of 200 R) the deposition density's fluctuation
                    at y = 200: 15 % and 20 % (sec. V), the relative standard deviation of the
                    strips of 4 R between 180 and 220 R about a line in each member, within a
                    quarter of the paper's value or t95 of it (narrower boxes
                    are not judged: how the fluctuation scales with the width is not known)
  A, Bo >= 1e4      the parabola cannot be identified: the fluctuations are too large (the
                    parabola claim above fails)
  C                 nu_i(y) and nu_f(y) are flat in the bulk (from a quarter of the deposit's
                    height, or `lower_half_from` if higher, to half of it: slope within t95 of
                    its jackknife error of zero); the final density predicted from the initial one
                    and the line Delta y(y_e) matches the measured one up to `cut_top` below
                    the lowest member's top (the deviation's mean over the strips and its slope
                    each within its 99.5 % bound, errors the program's jackknife of each over
                    the members, `nu/deviation_terms`); and dnu/nu_i stays
                    below its upper limit nu_rcp/nu_i - 1 (the paper: 1.19, random close packing
                    nu_rcp = 0.84 over nu_i ~ 0.38)

and, across the points of a scan (the fits in `analysis/`, made when three or more points
differ only in that variable; each point's error widened for the few members it comes from, as
docs/OUTPUT.md says; each fit must also be acceptable, its chi2 below the 99 % quantile, or the
law it claims is rejected):

  A, Bond numbers   the typical avalanche size falls as Bo rises: over three or more points
                    with 0 < Bo < inf that differ only in Bo, mean |Delta y| at the smallest Bo
                    exceeds that at the largest beyond t95 of their combined standard errors
                    (the fewer members'), and it rises by no more than that between
                    neighbouring Bond numbers
  A, Bo = 1e2, 1e3  the deposition density fluctuates more at Bo = 1e3 than at 1e2 at y = 200
                    (the paper: 20 % against 15 %): the ratio above one beyond t95 of its error,
                    points of one box from H = 220 on, at any width

  A, heights        the curvature of Delta y(y_e) scales like 1/H: the exponent p of
                    c2 = A H^p below zero and within two standard errors of -1 (fig. 7)
  A, heights        the slice model's a stays fixed (Delta y = H f(y/H), which makes c fall
                    like 1/H): the exponent p of a = A H^p within two standard errors of 0; a
                    wide error passes it, so read it beside the exponent's error
  C, heights        dnu/nu_i grows with ln H: slope above zero by two standard errors (fig. 16)
  C, r_capt         dnu/nu_i falls with nu_i as a power law: exponent below zero by two
                    standard errors (fig. 17; the paper's is -1.64)

The profile fits are unweighted least squares through the bins' pooled means (at least 10 disks,
every member's disks in it), their errors a jackknife over the members (each left out in turn),
and their chi2 that of the residuals against the residuals' own jackknife errors, each such t of
n - 1 degrees of freedom mapped to the chi2 term of its tail probability, scaled by
(bins - parameters)/bins, as the program's fits (docs/OUTPUT.md, "Analysis"). That chi2 counts
neighbouring bins, which move together, as independent, and rejects a right model more often
than 1 %; so a profile model is judged by the term it lacks instead: the highest coefficient of
the fit one degree higher over its jackknife error, a Student's t with n - 1 degrees of freedom,
within its two-sided 99 % quantile (t_quantile) for the model to be acceptable, beyond it for the
term to be there (for members whose coefficients scatter about normally; a rare member far off
the others makes the t's tails heavier). The histograms' shapes are judged the same way, by their
next two terms, each within its two-sided 99.5 % bound (the program's verdict; and the tail at
Bo = 0 here, fitted as the program fits: ln n a polynomial, the counts Poisson's, by maximum
likelihood over the bins between the counts' 0.5 % and 99.5 % quantiles; log_count_fit).
A difference whose error comes from n members (a jackknife over them, or their standard error)
is a Student's t with n - 1 degrees of freedom: t95 is its two-sided 95 % bound (3.18 at 4
members, 2.36 at 8, 2.13 at 16), where two errors would reject a true "within" claim in 14 % of
ensembles of 4 members rather than 5 %. The exponents of the fits across points, whose errors
follow from the points' own errors, are judged at two of them.

Histogram claims use the cut histogram (`shape_cut`: without the bottom and top
`cut_bottom`/`cut_top` of the deposit, as the paper does) when it has a verdict, else the whole
one. Prints one line per claim: PASS or FAIL with the numbers, or SKIP with what is missing where
the file holds too little to judge it (too few members, bins or strips). Exits with status 1 when
any claim fails, 2 when the file has nothing to judge (no claim, or every one skipped) or cannot
be read (and for a usage error).
Uses Debian's python3-h5py.
"""
import math
import sys

try:
    import h5py
    import numpy as np
except ImportError as e:  # pragma: no cover
    sys.exit(f"claims.py: {e}; install python3-h5py (scripts/install-deps.sh)")

Z99 = 2.3263  # the standard normal's 99 % quantile


RCP = 0.84  # 2D random close packing of disks: the paper's upper limit of the collapse
NOT_JUDGED = None  # a claim's verdict where the file holds too little to judge it


def chi2_quantile99(dof):
    """The 99 % quantile of chi2 with dof degrees of freedom (Wilson and Hilferty); NaN without
    a degree of freedom (a fit with as many parameters as points, or of a single member)."""
    if not dof > 0:
        return math.nan
    a = 2.0 / (9.0 * dof)
    return dof * (1.0 - a + Z99 * math.sqrt(a)) ** 3


def chi2_term_of_t(t, nu):
    """The square of the normal deviate with the tail probability of Student's t with nu degrees
    of freedom at t (Wallace 1959), as the program's (src/analysis.cpp, chi2_term_of_t): a
    deviation against an error estimated from nu + 1 members is such a t, and these terms sum to
    chi2's distribution, tail included."""
    c = (8 * nu + 1) / (8 * nu + 3)
    return c * c * nu * np.log1p(np.square(t) / nu)


Z995, Z9975 = 2.5758, 2.8070  # the standard normal's 99.5 % and 99.75 % quantiles


def t_quantile(nu, z=Z995):
    """Student's t with nu degrees of freedom at the tail probability of the normal deviate z
    (chi2_term_of_t inverted; at Z995 the two-sided 99 % quantile: 6.05 at nu = 3 against the
    exact 5.84, 3.51 at 7 against 3.50, 2.948 at 15 against 2.947); NaN for nu < 3."""
    if not nu >= 3:
        return math.nan
    c = (8 * nu + 1) / (8 * nu + 3)
    return math.sqrt(nu * math.expm1(z * z / (c * c * nu)))


Z975 = 1.9600  # the standard normal's 97.5 % quantile


def t95(members):
    """The two-sided 95 % bound of Student's t with members - 1 degrees of freedom: how far an
    estimate may lie from its expectation, in errors estimated from that many members (a
    jackknife over them, or their scatter), before it differs (3.18 at 4 members, 2.36 at 8,
    2.13 at 16; Student's table at 2 to 4 members, 12.71, 4.30 and 3.18, where t_quantile's
    expansion is off by 1.2 % or more; from 5 members on within 0.6 %); NaN for fewer than 2."""
    nu = members - 1
    if nu < 1:
        return math.nan
    return {1: 12.706, 2: 4.303, 3: 3.182}.get(nu) or t_quantile(nu, Z975)


def residual_chi2(resid, resid_err, members, params):
    """chi2 of residuals against their own jackknife errors over the members, as the program's
    fits (src/analysis.cpp, ResidualChi2): each z a t with members - 1 degrees of freedom, mapped
    to its chi2 term (chi2_term_of_t), and the sum scaled by (terms - params)/terms, since each
    residual's own error already holds the fit's freedom (the sum has the expectation of its
    terms, not of the degrees of freedom); NaN with 3 or fewer members or no freedom left."""
    resid, resid_err = np.asarray(resid, float), np.asarray(resid_err, float)
    ok = resid_err > 0
    terms = int(ok.sum())
    if members <= 3 or terms <= params:
        return math.nan
    z2 = float(chi2_term_of_t(resid[ok] / resid_err[ok], members - 1).sum())
    return z2 * (terms - params) / terms


def scaled_replicas(total, rows):
    """The total of the members' rows without each member in turn, scaled to the whole
    ensemble's (n / (n - 1)): the replicas a jackknife of counts refits."""
    n = len(rows)
    return [(total - r) * n / (n - 1) for r in rows]


def jackknife(values):
    """The jackknife error of leave-one-out estimates (rows: the member left out), column by
    column over the finite replicas (a replica without a value there is skipped), NaN with
    fewer than two: as the program's jackknife_error (src/analysis.cpp)."""
    v = np.asarray(values, float)
    if v.ndim == 1:
        return jackknife(v[:, None])[0]
    finite = np.isfinite(v)
    n = finite.sum(axis=0).astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(finite, v, 0.0).sum(axis=0) / n
        ss = np.where(finite, (v - mean) ** 2, 0.0).sum(axis=0)
        err = np.sqrt((n - 1) / n * ss)
    return np.where(n >= 2, err, np.nan)


class Profile:
    """A binned avalanche profile's per-member rows in a band of heights: the pooled means of
    all members and of all but one, for fits with jackknife errors."""

    def __init__(self, group, low, high, members=None, bins=None):
        """members: a mask of the members to take (all with disks when None); bins: a mask of
        the bins it may take (all when None), of which it takes those its members fill
        (`use`)."""
        count = group["member_count"][()]
        mean = group["member_mean"][()]
        pos = group["member_position"][()]
        ok = count.sum(axis=1) > 0  # failed members have no disks
        if members is not None:
            ok &= members
        count, mean, pos = count[ok], np.nan_to_num(mean[ok]), np.nan_to_num(pos[ok])
        centre = group["centre"][()]
        use = (count.sum(axis=0) >= 10) & (count > 0).all(axis=0) & (centre >= low) & \
            (centre <= high)
        if bins is not None:
            use &= bins
        self.use = use
        self.count, self.mean, self.pos = count[:, use], mean[:, use], pos[:, use]
        self.members, self.bins = self.count.shape

    def pooled(self, leave_out=None):
        keep = np.ones(self.members, bool)
        if leave_out is not None:
            keep[leave_out] = False
        c = self.count[keep]
        n = c.sum(axis=0)
        return (c * self.pos[keep]).sum(axis=0) / n, (c * self.mean[keep]).sum(axis=0) / n

    def fit(self, degree):
        """Coefficients (c0, c1, ...), their jackknife errors, chi2 and dof; None when the band
        has too few bins or members (4)."""
        dof = self.bins - degree - 1
        if dof < 1 or self.members < 4:
            return None
        x, y = self.pooled()
        coef = np.polynomial.polynomial.polyfit(x, y, degree)
        resid = y - np.polynomial.polynomial.polyval(x, coef)
        loo_coef, loo_resid = [], []
        for m in range(self.members):
            xm, ym = self.pooled(m)
            cm = np.polynomial.polynomial.polyfit(xm, ym, degree)
            loo_coef.append(cm)
            loo_resid.append(ym - np.polynomial.polynomial.polyval(xm, cm))
        err, resid_err = jackknife(loo_coef), jackknife(loo_resid)
        return coef, err, residual_chi2(resid, resid_err, self.members, degree + 1), dof


def cuts(point):
    """The point's `cut_bottom` and `cut_top`: its own (written where the scan sets them), else
    the file's settings', else the program's default, 20 R or a sixth of the height if less."""
    a, h = point.attrs, float(point.attrs["height"])
    settings = point.file["settings"].attrs if "settings" in point.file else {}
    default = min(20.0, h / 6)
    return tuple(float(a[k]) if k in a else float(settings.get(k, default))
                 for k in ("cut_bottom", "cut_top"))


def profile_shapes(point, path):
    """The avalanche profile Delta y(y_e) in the band between the cuts: the polynomial fits of
    degrees 0 to 3 (Profile.fit) and the members behind them."""
    group = point.get("avalanche_by_ye")
    if group is None or "member_mean" not in group:
        fail_missing(path, f"{point.name}/avalanche_by_ye/member_mean")
    bottom, top = cuts(point)
    low, high = bottom, float(point.attrs["height"]) - top
    prof = Profile(group, low, high)
    return (low, high), [prof.fit(d) for d in range(4)], prof.members


def top_t(fit):
    """The t of a fit's highest coefficient (its value over its jackknife error): the term the
    polynomial of one degree less lacks."""
    coef, err = fit[0], fit[1]
    return coef[-1] / err[-1]


def parabola_verdict(band, fits, members):
    """(parabola holds, constant acceptable, detail) from the band's fits of degrees 0 to 3.
    Each model is judged by the term it lacks, the t of the next degree's highest coefficient,
    against Student's t with members - 1 degrees of freedom: the jackknife over whole members
    carries the bins' correlation, which a chi2 of the residuals counts as independent. The
    parabola holds when its curvature c2 is positive and beyond the two-sided 99 % bound, its
    vertex inside the band and its cubic term within the bound (not judged where the band has too
    few bins for a cubic); the constant is acceptable when neither the line's slope nor the
    parabola's curvature is beyond the bound at 99.5 % (both together within 1 %)."""
    if any(f is None for f in fits[:3]):
        return NOT_JUDGED, NOT_JUDGED, "too few bins or members in the band between the cuts"
    nu = members - 1
    bound, bound2 = t_quantile(nu), t_quantile(nu, Z9975)
    t1, t2 = top_t(fits[1]), top_t(fits[2])
    t3 = top_t(fits[3]) if fits[3] is not None else math.nan
    (c0, e0, _, _), (c2, e2, x2, d2) = fits[0], fits[2]
    curv, curv_err = c2[2], e2[2]
    vertex = -c2[1] / (2 * curv) if curv != 0 else math.inf
    holds = t2 > bound and band[0] < vertex < band[1]
    if holds:
        holds = abs(t3) <= bound if fits[3] is not None else NOT_JUDGED
    constant = abs(t1) <= bound2 and abs(t2) <= bound2
    cubic = f"{t3:.3g}" if fits[3] is not None else "not fitted (too few bins)"
    detail = (f"band {band[0]:g}-{band[1]:g} R: c2 = {curv:.3g} +- {curv_err:.2g}, vertex "
              f"{vertex:.3g} R; t of the line's slope {t1:.3g}, of the parabola's c2 {t2:.3g}, of "
              f"the cubic's c3 {cubic} (99 % bound {bound:.3g}, 99.5 % {bound2:.3g}; {members} "
              f"members); parabola chi2/dof {x2:.3g}/{d2}; constant {c0[0]:.3g} +- {e0[0]:.2g} R")
    return holds, constant, detail


def unusable(message):
    """Input the claims cannot be judged on: the message, and exit status 2."""
    print(message, file=sys.stderr)
    sys.exit(2)


def check_result_file(f, path, tool):
    """Exits with status 2 unless `f` is a loosepack result file: /points, and the scan text (a
    dataset, or in older files a root attribute)."""
    if "points" not in f or ("scan_text" not in f and "scan_text" not in f.attrs):
        unusable(f"{tool}: {path} is not a loosepack result file (no /points or /scan_text): "
                 "give the file `loosepack run` wrote")


class DamagedFile(Exception):
    """What a file holds is not what the program writes (check_attributes)."""


# The attributes of groups the program writes as strings (a point's protocol, a histogram's
# preferred shape, a failed member's failure, the choices among the settings: src/settings.cpp);
# every other is a number.
STRING_ATTRIBUTES = ("protocol", "preferred", "failure", "solver_kind", "stop_rule")


def check_attributes(group):
    """DamagedFile unless every attribute of `group` and of the groups below it is of the type
    the program writes: those in STRING_ATTRIBUTES strings, every other a number."""
    for key, value in group.attrs.items():
        string = isinstance(value, (bytes, str))
        if string != (key in STRING_ATTRIBUTES) or (not string and np.ndim(value) != 0):
            raise DamagedFile(f"{group.name}: attribute '{key}' holds {value!r}, not a "
                              f"{'string' if key in STRING_ATTRIBUTES else 'number'}")
    for sub in group.values():
        if isinstance(sub, h5py.Group):
            check_attributes(sub)


def read_damaged_as_unusable(read, path, where):
    """read(), with a dataset or attribute the file lacks (KeyError) or holds in another type
    (DamagedFile) taken as a damaged file: exit 2, naming the file and the group, not a
    traceback."""
    try:
        return read()
    except (KeyError, DamagedFile) as e:
        unusable(f"claims.py: {path}: {where}: cannot read what the claims need ({e}): the file is "
                 "damaged or was edited")


def fail_missing(path, name):
    if "member_" in name:  # rows the run writes (files from 2026-11-24 on), no analysis can add
        unusable(f"claims.py: {path}: '{name}' is missing (was the file written by loosepack? "
                 "the members' rows come from the run itself, which an older program did not "
                 "write: run the scan again with the present program)")
    unusable(f"claims.py: {path}: '{name}' is missing (was the file written by loosepack? "
             f"`loosepack analyse {path}` adds the current analysis to a file of an older one)")


def fit(group, path):
    for part in ("coef", "error"):
        if part not in group:
            fail_missing(path, f"{group.name}/{part}")
    return list(group["coef"][()]), list(group["error"][()]), dict(group.attrs)


def text(v):
    return v.decode() if isinstance(v, bytes) else str(v)


def attribute_value(v):
    """An attribute as compared: a string as text, else a number."""
    return text(v) if isinstance(v, (bytes, str)) else float(v)


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


def log_count_fit(x, n, degree):
    """ln n = polynomial of `degree` in x (coefficients c0, c1, ...), fitted to the counts n as
    Poisson's by maximum likelihood, empty bins included, as the program's histogram shapes
    (src/analysis.cpp, log_count_fit): iteratively reweighted least squares, a step halved while
    it lowers the likelihood. None where no more bins than `degree` hold counts (no maximum) or
    the iterations do not settle."""
    x, n = np.asarray(x, float), np.asarray(n, float)
    if int((n > 0).sum()) <= degree:
        return None
    basis = np.vander(x, degree + 1, increasing=True)

    def solve(z, w):
        sw = np.sqrt(w)
        return np.linalg.lstsq(basis * sw[:, None], z * sw, rcond=None)[0]

    def likelihood(c):
        eta = basis @ c
        return eta, float((n * eta - np.exp(eta)).sum())

    c = solve(np.log(n + 0.5), n + 0.5)
    eta, ll = likelihood(c)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        for _ in range(100):
            mu = np.exp(eta)
            step = solve(eta + (n - mu) / mu, mu)
            new_eta, new_ll = likelihood(step)
            for _ in range(40):
                if new_ll >= ll:
                    break
                step = 0.5 * (step + c)
                new_eta, new_ll = likelihood(step)
            change = float(np.abs(new_eta - eta).max())
            c, eta, ll = step, new_eta, new_ll
            if not np.all(np.isfinite(c)):
                return None
            if change < 1e-10:
                return c
    return None


SHAPE_TAIL = 0.005  # the program's kShapeTail (src/analysis.cpp)


def shape_band(counts):
    """The bins the program fits the histogram shapes to: from the one that holds the counts'
    SHAPE_TAIL quantile to the one that holds their 1 - SHAPE_TAIL quantile (a boolean mask)."""
    cumulative = np.cumsum(counts)
    whole = cumulative[-1] if len(cumulative) else 0.0
    k = np.arange(len(cumulative))
    return ((cumulative > SHAPE_TAIL * whole) &
            (k <= np.searchsorted(cumulative, (1 - SHAPE_TAIL) * whole)))


class Histogram:
    """The cut |Delta y| histogram's per-member counts (`member_counts_cut`), for fits with errors
    from the members' scatter, as the program's shapes (docs/OUTPUT.md, "Analysis"): ln n a
    polynomial in |Delta y| fitted to the counts as Poisson's over the bins between the counts'
    0.5 % and 99.5 % quantiles (log_count_fit), errors a jackknife over the members (the others'
    counts scaled to the whole ensemble's), chi2 the counts' residuals against the residuals'
    jackknife errors (residual_chi2), and the fit's next two terms as t's."""

    def __init__(self, group, path):
        if "member_counts_cut" not in group:
            fail_missing(path, f"{group.name}/member_counts_cut")
        edges = group["edges"][()]
        rows = group["member_counts_cut"][()]
        failure = group.parent.get("members/failure")
        if failure is not None and len(failure) == len(rows):
            self.kept = failure[()] == 0  # a member may finish with no disk in the band
        else:
            self.kept = rows.sum(axis=1) > 0  # failed members have no disks
        self.rows = rows[self.kept]
        self.edges = edges
        self.centre = 0.5 * (edges[1:] + edges[:-1])
        self.total = self.rows.sum(axis=0)
        self.members = len(self.rows)
        self.band = shape_band(self.total)

    def replicas(self):
        """The other members' counts scaled to the whole ensemble's, one per member left out."""
        return scaled_replicas(self.total, self.rows)

    def fit(self, degree, use):
        """(coefficients (c0, c1, ...) of ln n, their errors, chi2, dof, the t's of the next two
        terms) over the bins `use` within the band; None with fewer than 4 members, no degree of
        freedom, or a fit that does not exist (without some member, too)."""
        use = use & self.band
        x, dof = self.centre[use], int(use.sum()) - degree - 1
        if dof < 1 or self.members < 4:
            return None

        def with_jackknife(d):
            coef = log_count_fit(x, self.total[use], d)
            loo = [log_count_fit(x, r[use], d) for r in self.replicas()]
            if coef is None or any(c is None for c in loo):
                return None
            resid = lambda counts, c: counts - np.exp(np.polynomial.polynomial.polyval(x, c))
            return (coef, jackknife(loo), resid(self.total[use], coef),
                    jackknife([resid(r[use], c) for r, c in zip(self.replicas(), loo)]))

        model = with_jackknife(degree)
        if model is None:
            return None
        coef, err, resid, resid_err = model

        def top_t(d):
            f = with_jackknife(d) if int(use.sum()) > d + 1 else None
            return f[0][-1] / f[1][-1] if f is not None else math.nan

        return (coef, err, residual_chi2(resid, resid_err, self.members, degree + 1), dof,
                (top_t(degree + 1), top_t(degree + 2)))


def terms_hold(ts, members):
    """Whether a fit's terms (t's with members - 1 degrees of freedom; the next two, as the
    program judges the histogram shapes, at most 1 % of right shapes failing) are each within
    their two-sided 99.5 % bound; False where a term has no t."""
    return all(math.isfinite(t) and chi2_term_of_t(t, members - 1) <= Z9975 ** 2 for t in ts)


def folded_normal_in_bins(lo, hi, mean, sd):
    """The probability that |v| lies in each bin [lo, hi) for v normal about `mean` with `sd`."""
    cdf = lambda v: 0.5 * (1.0 + np.vectorize(math.erf)((v - mean) / (sd * math.sqrt(2.0))))
    return cdf(hi) - cdf(lo) + cdf(-lo) - cdf(-hi)


class SliceMixture:
    """The cut |Delta y| histogram as the sum of its height slices' Gaussians: the paper's
    picture behind fig. 8 ("the average of the avalanche size Delta y as function of the vertical
    position shows a parabolic profile [...] there are of course large fluctuations around this
    value"). In each member, the disks of each bin of Delta y(y_e) (`avalanche_by_ye`) whose
    centre lies within the cut (from `cut_bottom` to the member's top less `cut_top`) are taken
    as normal about the member's mean in that bin, with the bin's spread within members (its
    pooled variance less that of the members' means about it); |Delta y| folds it at 0. Such a
    sum is no Gaussian where the profile's means spread over the cut as widely as the disks
    scatter about them."""

    def __init__(self, point, hist):
        prof = point["avalanche_by_ye"]
        centre = prof["centre"][()]
        count, mean = prof["member_count"][()], np.nan_to_num(prof["member_mean"][()])
        pooled_mean, pooled_sd = prof["mean"][()], prof["stddev"][()]
        disks = count.sum(axis=0)
        between = (count * (mean - np.nan_to_num(pooled_mean)) ** 2).sum(axis=0)
        groups = (count > 0).sum(axis=0)
        within = ((disks - 1) * np.nan_to_num(pooled_sd) ** 2 - between) / np.maximum(
            1.0, disks - groups)
        sd = np.sqrt(np.maximum(within, 1e-12))
        bottom, top_cut = cuts(point)
        tops = point["members/top"][()]
        lo, hi = hist.edges[:-1], hist.edges[1:]
        self.rows = []
        for m in np.flatnonzero(hist.kept):
            row = np.zeros(hist.centre.size)
            for b in np.flatnonzero((count[m] > 0) & (centre >= bottom) &
                                    (centre <= tops[m] - top_cut)):
                row += count[m, b] * folded_normal_in_bins(lo, hi, mean[m, b], sd[b])
            self.rows.append(row)
        self.rows = np.array(self.rows)
        self.total = self.rows.sum(axis=0)
        # the profile's spread over the cut against the scatter about it, each bin weighted by
        # its disks: a sum of Gaussians is skewed where the first is not small beside the second
        band = (disks > 1) & (centre >= bottom) & (centre <= tops[hist.kept].mean() - top_cut)
        w = disks[band] / disks[band].sum()
        spread = pooled_mean[band] - (w * pooled_mean[band]).sum()
        self.spread = float(np.sqrt((w * spread ** 2).sum()))
        self.scatter = float(np.sqrt((w * pooled_sd[band] ** 2).sum()))

    @staticmethod
    def missing(point):
        """Why the point's file cannot give the sum (per-member histogram counts, profile rows or
        members' tops missing), or None."""
        h, prof = point["abs_dy_histogram"], point.get("avalanche_by_ye")
        if ("members" in point and "top" in point["members"] and "member_counts_cut" in h and
                prof is not None and
                all(k in prof for k in ("member_count", "member_mean", "stddev"))):
            return None
        return "the file has no per-member histogram counts, profile rows or members' tops"

    def replicas(self):
        """The sum without each member in turn, scaled to the whole ensemble's."""
        return scaled_replicas(self.total, self.rows)


def mixture_terms(hist, mixture):
    """The measured cut histogram's shape terms beside its slices' mixture's: for the fits of
    degrees 2, 3 and 4 over the histogram's band (log_count_fit), the top coefficient measured,
    the mixture's, and the t of their difference (its jackknife error over the members, each left
    out of both); None where a fit does not exist."""
    x, band = hist.centre[hist.band], hist.band
    top = lambda counts, d: log_count_fit(x, counts[band], d)
    out = []
    for d in (2, 3, 4):
        pairs = [(top(h, d), top(m, d)) for h, m in
                 [(hist.total, mixture.total)] + list(zip(hist.replicas(), mixture.replicas()))]
        if any(c is None for pair in pairs for c in pair):
            return None
        measured, mixed = pairs[0][0][-1], pairs[0][1][-1]
        err = float(jackknife([h[-1] - m[-1] for h, m in pairs[1:]]))
        measured_err = float(jackknife([h[-1] for h, _ in pairs[1:]]))
        out.append((measured, measured_err, mixed, (measured - mixed) / err))
    return out


def slice_mixture_claim(point, path, where):
    """Bo = 1e3: the cut |Delta y| histogram's skew is that of its height slices' Gaussians
    summed (SliceMixture): its cubic term the sum's within the two-sided 99 % bound of their
    difference's t. The quadratic and quartic terms are shown beside it, not judged: they follow
    the slices' own shapes (a tail heavier than a Gaussian's in a few members), which the sum
    does not model; the cubic's t against the measured error says what the profile alone makes
    of the Gaussian's verdict."""
    claim = f"{where}: the cut |Delta y| histogram's skew is its height slices' Gaussians' sum's"
    why = SliceMixture.missing(point)
    if why is not None:
        yield (claim, NOT_JUDGED, why)
        return
    hist = Histogram(point["abs_dy_histogram"], path)
    if hist.members < 4:
        yield (claim, NOT_JUDGED, f"{hist.members} members (4 needed)")
        return
    mixture = SliceMixture(point, hist)
    terms = mixture_terms(hist, mixture)
    if terms is None:
        yield (claim, NOT_JUDGED, "too few bins for the fits of degree 4")
        return
    names = ("quadratic", "cubic", "quartic")
    detail = "; ".join(f"{n} {c:.3g} +- {e:.2g}, the sum's {mc:.3g} (difference's t {t:.3g})"
                       for n, (c, e, mc, t) in zip(names, terms))
    cubic, cubic_err, cubic_sum, t = terms[1]
    bound = t_quantile(hist.members - 1)
    yield (claim, abs(t) <= bound,
           f"{detail} (bound {bound:.3g}; {hist.members} members); the sum's cubic over the "
           f"measured error {cubic_sum / cubic_err:.3g}; the profile's means spread over the cut "
           f"by {mixture.spread:.3g} R, the disks about them by {mixture.scatter:.3g} R")


def bo0_histogram_claims(point, path, where):
    """Bo = 0 (fig. 9): "basically shows an exponential decay. Deviation from this behavior can
    be found for |Delta y| between 1 and 2 particle radii where the probability is about
    constant": the decay beyond 2 R an acceptable exponential, and the bins between 1 and 2 R
    one constant (chi2 of their mean against the jackknife errors of each bin's difference
    from it, within its 99 % quantile)."""
    if "member_counts_cut" not in point["abs_dy_histogram"]:  # a file before 2026-11-26
        why = ("the file has no per-member counts (`abs_dy_histogram/member_counts_cut`, in files "
               "from 2026-11-26 on): run the scan again to judge it")
        yield (f"{where}: the |Delta y| histogram decays exponentially beyond 2 R", NOT_JUDGED, why)
        yield (f"{where}: the |Delta y| histogram is flat between 1 and 2 R", NOT_JUDGED, why)
        return
    hist = Histogram(point["abs_dy_histogram"], path)
    tail = hist.fit(1, hist.centre > 2.0)
    if tail is None or not all(math.isfinite(t) for t in tail[4]):
        yield (f"{where}: the |Delta y| histogram decays exponentially beyond 2 R", NOT_JUDGED,
               "too few bins or members beyond 2 R" if tail is None else
               "too few bins beyond 2 R to test the line's next terms")
    else:
        coef, err, chi2, dof, ts = tail
        yield (f"{where}: the |Delta y| histogram decays exponentially beyond 2 R",
               coef[1] < -t95(hist.members) * err[1] and terms_hold(ts, hist.members),
               f"decay length {-1 / coef[1]:.3g} R (slope {coef[1]:.3g} +- {err[1]:.2g} per R), "
               f"t of the quadratic term {ts[0]:.3g}, of the cubic {ts[1]:.3g} (bound "
               f"{t_quantile(hist.members - 1, Z9975):.3g}), chi2/dof {chi2:.3g}/{dof}, "
               f"{hist.members} members")
    band = (hist.centre > 1.0) & (hist.centre < 2.0)
    if band.sum() < 2 or hist.members < 4:
        yield (f"{where}: the |Delta y| histogram is flat between 1 and 2 R", NOT_JUDGED,
               "fewer than two bins between 1 and 2 R, or fewer than 4 members")
        return
    diff = lambda counts: counts[band] - counts[band].mean()
    err = jackknife([diff(r) for r in hist.replicas()])
    dof = int(band.sum()) - 1
    chi2 = residual_chi2(diff(hist.total), err, hist.members, 1)
    counts = ", ".join(f"{c:g}" for c in hist.total[band])
    yield (f"{where}: the |Delta y| histogram is flat between 1 and 2 R",
           chi2 <= chi2_quantile99(dof),
           f"disks per bin {counts}; chi2/dof of a constant {chi2:.3g}/{dof} (99 % bound "
           f"{chi2_quantile99(dof):.3g})")


PAPER_FLUCTUATION = {100.0: 0.15, 1000.0: 0.20}  # nu_d at y = 200 (the paper, sec. V)
PAPER_WIDTH = 200.0  # R: the paper's box


def deposition_fluctuation(point):
    """The deposition density's fluctuation at y = 200 (member_fluctuations): the members' mean
    and its standard error, their number and the strips' centres. None where the deposit does not
    reach 220 R in two members or more."""
    found = member_fluctuations(point)
    return None if found is None else fluctuation_summary(*found)


def fluctuation_summary(rel, x=None):
    """(mean, standard error, members, strips' centres) of members' fluctuations `rel`."""
    return float(np.mean(rel)), float(np.std(rel, ddof=1) / math.sqrt(len(rel))), len(rel), x


def member_fluctuations(point):
    """In each member, the relative standard deviation of the strips of nu_d(y_i) with centres
    from 180 to 220 R about a straight line through them (over the strips' mean), and the strips'
    centres. None where the deposit does not reach 220 R in two members or more."""
    group = point.get("nu_deposition")
    if group is None or "member_mean" not in group:
        return None
    centre, rows = group["centre"][()], group["member_mean"][()]
    rows = rows[np.isfinite(rows).all(axis=1)]  # failed members' rows are NaN
    window = (centre >= 180.0) & (centre <= 220.0)
    covered = window.sum() >= 5 and centre[window].max() + 4.0 >= 220.0 and \
        (rows[:, window] > 0).all()
    if not covered or len(rows) < 2:
        return None
    x = centre[window]
    rel = []
    for row in rows:
        y = row[window]
        line = np.polynomial.polynomial.polyval(x, np.polynomial.polynomial.polyfit(x, y, 1))
        rel.append(float(np.sqrt(((y - line) ** 2).sum() / (len(y) - 2)) / y.mean()))
    return rel, x


def deposition_fluctuation_claims(point, path, where):
    """Bo = 1e2 and 1e3 in a box of the paper's width (200 R): "the fluctuations of the
    deposition density at vertical position y = 200": around 15 % and 20 %, read as the
    relative standard deviation of strips of two diameters (deposition_fluctuation). It holds
    within a quarter of the paper's value (our reading of "around") or t95 of its error. Narrower boxes are not judged: the fluctuations come from avalanches whose lateral
    extent is not known, so how they scale with the width is not either."""
    if float(point.attrs["width"]) < PAPER_WIDTH:
        return
    bo = float(point.attrs["bond_number"])
    claim = (f"{where}: the deposition density fluctuates by about {PAPER_FLUCTUATION[bo]:.0%} "
             f"at y = 200")
    if "nu_deposition" not in point or "member_mean" not in point["nu_deposition"]:
        fail_missing(path, f"{point.name}/nu_deposition/member_mean")
    fl = deposition_fluctuation(point)
    if fl is None:
        yield (claim, NOT_JUDGED, "no deposit above 220 R in two members or more")
        return
    value, error, members, x = fl
    paper = PAPER_FLUCTUATION[bo]
    yield (claim, abs(value - paper) <= max(0.25 * paper, t95(members) * error),
           f"{value:.1%} +- {error:.1%} in strips {x[0]:g}-{x[-1]:g} R, {members} members")


# A point's system parameters but its protocol and Bond number, and what follows from Bo (the
# cohesive force, the default time step) or sets units only (gravity, the disks' density): points
# equal in these differ only in Bo, as far as the physics goes.
SYSTEM_BUT_BOND = ("width", "height", "friction", "rolling_friction", "cohesion_range", "radius",
                   "polydispersity", "capture_radius", "floor_cohesion")


def same_system(attrs):
    """The key of a point's SYSTEM_BUT_BOND values: points with equal keys differ only in Bo."""
    return tuple((k, float(attrs[k])) for k in sorted(attrs) if k in SYSTEM_BUT_BOND)


def deposition_fluctuation_order(f):
    """Points of protocol A at Bo = 1e2 and 1e3 in the same box (H >= 220): the paper's "the
    deposition density shows somewhat lower fluctuations as for Bo = 1e3" (15 % against 20 %):
    the ratio above one beyond t95 of its error (the fewer members'), at any width."""
    points = ((name, f["points"][name]) for name in sorted(f["points"]))
    for key, by_bo in fluctuations_by_box(points).items():
        if len(by_bo) < 2:
            continue
        width, height = dict(key)["width"], dict(key)["height"]
        yield (f"A across Bond numbers ({width:g} x {height:g}): the deposition density "
               f"fluctuates more at Bo = 1e3 than at 1e2", *fluctuation_order(by_bo))


def fluctuations_by_box(points):
    """{box (same_system): {Bo: [(label, members' fluctuations)]}} over the (label, point group)
    pairs `points` of protocol A at Bo = 1e2 and 1e3 whose deposits reach 220 R
    (member_fluctuations)."""
    found = {}
    for label, g in points:
        bo = float(g.attrs["bond_number"])
        if text(g.attrs["protocol"]) != "A" or bo not in PAPER_FLUCTUATION:
            continue
        members = member_fluctuations(g)
        if members is not None:
            found.setdefault(same_system(g.attrs), {}).setdefault(bo, []).append(
                (label, members[0]))
    return found


def fluctuation_order(by_bo):
    """(ok, detail): the fluctuations at Bo = 1e3 over those at 1e2, each the members of every
    run of its Bond number pooled (fluctuations_by_box), above one beyond t95 of the ratio's error
    (the fewer members')."""
    (v2, e2, n2, _), (v3, e3, n3, _) = (
        fluctuation_summary([v for _, rel in by_bo[bo] for v in rel]) for bo in (100.0, 1000.0))
    ratio = v3 / v2
    error = ratio * math.hypot(e2 / v2, e3 / v3)
    return (ratio - 1 > t95(min(n2, n3)) * error,
            f"{v2:.1%} +- {e2:.1%} ({n2} members) and {v3:.1%} +- {e3:.1%} ({n3}) at y = 200; "
            f"ratio {ratio:.3g} +- {error:.2g} (paper: 20 % / 15 % = 1.33)")


def check_point(point, path):
    """Yields (claim, ok, detail) for one scan point; ok is NOT_JUDGED where the point holds too
    little to judge the claim."""
    a = point.attrs
    protocol, bo = text(a["protocol"]), float(a["bond_number"])
    where = f"point {point.name.split('/')[-1]} ({protocol}, Bo = {bo:g}, H = {a['height']:g})"
    finished = int(a.get("members", 2)) - int(a.get("failed", 0))
    if finished < 2:
        yield (f"{where}: its claims", NOT_JUDGED,
               f"{finished} member{'' if finished == 1 else 's'} finished: no ensemble to judge")
        return
    if protocol == "A" and 0 < bo < 1e4 and not moved(point):
        yield (f"{where}: its avalanche profile and trajectory claims", NOT_JUDGED,
               f"nothing moved: mean |Delta y| {float(a['mean_abs_dy_mean']):.2g} R, below the "
               "event threshold")
    elif protocol == "A" and 0 < bo < 1e4:
        holds, _, detail = parabola_verdict(*profile_shapes(point, path))
        yield (f"{where}: Delta y(y_e) is a parabola with positive curvature", holds, detail)
        if "members" in point and any(k.startswith("trajectory_") for k in point["members"]):
            yield from trajectory_claims(point, where)
    if protocol == "A" and 1e4 <= bo < math.inf:
        holds, _, detail = parabola_verdict(*profile_shapes(point, path))
        yield (f"{where}: at Bo >= 1e4 no parabola can be identified",
               NOT_JUDGED if holds is NOT_JUDGED else not holds, detail)
    if protocol == "A" and bo == 0:
        holds, constant, detail = parabola_verdict(*profile_shapes(point, path))
        verdict = constant and not holds  # a parabola not judged leaves only the constant's
        if constant is NOT_JUDGED or (constant and holds is NOT_JUDGED):
            verdict = NOT_JUDGED
        yield (f"{where}: Delta y(y_e) is constant in the bulk, no parabola", verdict, detail)
    if protocol == "A" and bo in (0.0, 1e3):  # the two Bond numbers the paper says it of
        yield from histogram_claims(point, path, where)
    if protocol == "A" and bo in PAPER_FLUCTUATION and float(a["height"]) >= 220.0:
        yield from deposition_fluctuation_claims(point, path, where)
    if protocol == "C" and not moved(point):
        yield (f"{where}: its collapse claims", NOT_JUDGED,
               f"nothing collapsed: mean |Delta y| {float(a['mean_abs_dy_mean']):.2g} R, below "
               f"the event threshold")
    elif protocol == "C":
        yield from collapse_claims(point, path, where)
        yield from collapse_density_claims(point, path, where)


def moved(point):
    """Whether the point's disks moved by `event_threshold` or more on average (the program's
    fits across points leave out those that did not: their lines are round-off's)."""
    settings = point.file["settings"].attrs if "settings" in point.file else {}
    threshold = float(settings.get("event_threshold", 0.0))
    return not float(point.attrs.get("mean_abs_dy_mean", math.inf)) < threshold


def histogram_claims(point, path, where):
    """The |Delta y| histogram's shape at Bo = 0 (exponential, fig. 9) and Bo = 1e3 (Gaussian,
    fig. 8): the program's verdict, and at Bo = 0 the paper's description of fig. 9 besides."""
    bo = float(point.attrs["bond_number"])
    expected = "exponential" if bo == 0 else "gaussian"
    which, preferred, g = histogram_verdict(point, path)
    chi2 = lambda m: (f"{g[m].attrs['chi2']:.3g}/{g[m].attrs['dof']:g} (99 % bound "
                      f"{chi2_quantile99(g[m].attrs['dof']):.3g})")
    counted = "member_counts_cut" in point["abs_dy_histogram"]
    errors = ("the members' scatter" if g.attrs.get("member_errors", 0) else
              "Poisson's (" + ("fewer than 4 members with disks" if counted else
                               "a file without per-member counts") + ")")
    if preferred == "none":  # too few bins for any fit
        yield (f"{where}: |Delta y| histogram is {expected}", NOT_JUDGED,
               "too few bins (or members) for a shape fit")
    elif counted and not g.attrs.get("member_errors", 0):
        yield (f"{where}: |Delta y| histogram is {expected}", NOT_JUDGED,
               "fewer than 4 members with disks: no errors from their scatter to judge a shape by "
               "(Poisson's are far too small for counts that move together)")
    else:
        # the shapes' next terms, the quadratic and the cubic (files from 2026-12-02 on) and the
        # quartic (from 2026-12-03 on), which judge the shapes where the members give errors
        attr = lambda s, a: g[s].attrs.get(a, math.nan) if s in g else math.nan
        ts = [(name, attr(s, a)) for name, s, a in (
            ("quadratic", "exponential", "next_term_t"), ("cubic", "gaussian", "next_term_t"),
            ("quartic", "gaussian", "second_term_t"))]
        terms = ", ".join(f"{name} {t:.3g}" for name, t in ts if math.isfinite(t))
        bound = t_quantile(g.attrs.get("members", math.nan) - 1, Z9975)  # files from 2026-12-03
        detail = (f"{which}: preferred {preferred}; chi2/dof exponential {chi2('exponential')}, "
                  f"gaussian {chi2('gaussian')}, errors from {errors}"
                  + (f"; t of the terms: {terms}" if terms else "")
                  + (f" (bound {bound:.3g})" if terms and math.isfinite(bound) else ""))
        yield (f"{where}: |Delta y| histogram is {expected}", preferred == expected, detail)
    if bo == 0:
        yield from bo0_histogram_claims(point, path, where)
    else:
        yield from slice_mixture_claim(point, path, where)


NEIGHBOURS = 3.0  # R: centres within 1.5 diameters when the later disk lands
FAR_APART = 12.0  # R: sideways distance of the control pairs at the same height


class Trajectories:
    """One member's trajectory samples (`members/trajectory_K`: every k-th disk after every
    deposition) as paths: the increments dx (periodic), dy of each sampled disk between
    consecutive samples, from its first sample (after its own deposition came to rest). Kept
    per disk, not as a samples-by-disks table, which a paper-size member would make gigabytes."""

    def __init__(self, group, width):
        time, disk, x, y = (group[k][()] for k in ("time", "disk", "x", "y"))
        self.width = width
        self.times = np.unique(time)
        by_time = np.lexsort((disk, time))  # the samples of each time together
        self.t, self.d = time[by_time], disk[by_time]
        self.x, self.y = x[by_time], y[by_time]
        self.at = np.searchsorted(self.t, self.times)  # where each time's samples begin
        by_disk = np.lexsort((time, disk))
        ids, begin = np.unique(disk[by_disk], return_index=True)
        self.ids = ids
        self.first, self.dx, self.dy = [], [], []
        for a, b in zip(begin, list(begin[1:]) + [len(by_disk)]):
            k = by_disk[a:b]
            dx = np.diff(x[k])
            self.first.append(int(np.searchsorted(self.times, time[k[0]])))
            self.dx.append(dx - width * np.round(dx / width))
            self.dy.append(np.diff(y[k]))

    def displacement(self):
        """The sampled disks' mean downward and mean sideways displacement, from each one's
        first sample to the last."""
        return (-np.mean([dy.sum() for dy in self.dy]),
                np.mean([abs(dx.sum()) for dx in self.dx]))

    def pairs(self):
        """(i, j, t0) of the neighbours and of the pairs at the same height far apart sideways,
        at t0, the later one's first sample (disk indices into self.ids)."""
        near, far = [], []
        for j, t0 in enumerate(self.first):
            lo, hi = self.at[t0], self.at[t0 + 1] if t0 + 1 < len(self.at) else len(self.t)
            here = np.searchsorted(self.ids, self.d[lo:hi])
            first = np.asarray(self.first)[here]
            earlier = (first < t0) | ((first == t0) & (here < j))
            if not earlier.any():
                continue
            k = lo + np.flatnonzero(earlier)
            me = lo + np.flatnonzero(here == j)[0]
            sep_x = self.x[k] - self.x[me]
            sep_x -= self.width * np.round(sep_x / self.width)
            sep_y = self.y[k] - self.y[me]
            others = here[earlier]
            near += [(i, j, t0) for i in others[np.hypot(sep_x, sep_y) <= NEIGHBOURS]]
            same_height = (np.abs(sep_y) <= NEIGHBOURS) & (np.abs(sep_x) >= FAR_APART)
            far += [(i, j, t0) for i in others[same_height]]
        return near, far

    def cosines(self):
        """The mean cosine between two disks' paths from the later one's first sample on, of
        neighbours and of pairs at the same height far apart sideways (pairs where both moved
        at least 1 R in all)."""
        out = []
        for pairs in self.pairs():
            c = []
            for i, j, t0 in pairs:
                pa = [v[t0 - self.first[i]:] for v in (self.dx[i], self.dy[i])]
                pb = [v[t0 - self.first[j]:] for v in (self.dx[j], self.dy[j])]
                n = min(len(pa[0]), len(pb[0]))
                pa, pb = np.concatenate([v[:n] for v in pa]), np.concatenate([v[:n] for v in pb])
                if np.abs(pa).sum() >= 1.0 and np.abs(pb).sum() >= 1.0:
                    c.append(pa @ pb / np.sqrt((pa @ pa) * (pb @ pb)))
            out.append(np.mean(c) if c else math.nan)
        return out


def trajectory_claims(point, where):
    """Fig. 5: "The avalanches are a collective motion of parts of the system. This mainly
    downwards motion is accompanied by a sidewards motion or rotation. [...] Neighboring
    particles can have very similar trajectories", per member and judged with jackknife errors
    over the members."""
    width = float(point.attrs["width"])
    members = point["members"]
    failed = set()  # seeds of failed members, whose trajectories stop at the failure
    if "failure" in members and "seed_index" in members:
        failed = {int(s) for s, f in zip(members["seed_index"][()], members["failure"][()]) if f}
    rows = []
    for name in sorted(k for k in members if k.startswith("trajectory_")):
        if members[name]["time"].size == 0 or int(name.split("_")[1]) in failed:
            continue
        t = Trajectories(members[name], width)
        rows.append([*t.displacement(), *t.cosines()])
    rows = np.array(rows)
    claims = (f"{where}: the disks move mainly downwards, with sideways motion",
              f"{where}: neighbouring disks move together (similar trajectories)")
    if len(rows) < 4:
        for claim in claims:
            yield (claim, NOT_JUDGED, f"{len(rows)} members with trajectories (4 needed)")
        return
    replicas = [np.delete(rows, k, axis=0).mean(axis=0) for k in range(len(rows))]
    mean, err = rows.mean(axis=0), jackknife(replicas)
    down, side, near, far = mean
    down_err = float(jackknife([r[0] - r[1] for r in replicas]))
    bound = t95(len(rows))
    yield (claims[0], down - side > bound * down_err,
           f"mean displacement after deposition: {down:.3g} +- {err[0]:.2g} R down, "
           f"{side:.3g} +- {err[1]:.2g} R sideways (difference {down - side:.3g} +- "
           f"{down_err:.2g}), {len(rows)} members")
    if not np.isfinite(rows[:, 2:]).all():
        yield (claims[1], NOT_JUDGED,
               "a member without neighbours or far pairs that both moved 1 R")
        return
    near_err = float(jackknife([r[2] - r[3] for r in replicas]))
    yield (claims[1], near - far > bound * near_err,
           f"mean cosine of the paths: neighbours (within {NEIGHBOURS:g} R) {near:.3g} +- "
           f"{err[2]:.2g}, disks at the same height at least {FAR_APART:g} R apart "
           f"{far:.3g} +- {err[3]:.2g} (difference {near - far:.3g} +- {near_err:.2g})")


def collapse_claims(point, path, where):
    """Protocol C: Delta y is a straight line in y_e and in y_i (each acceptable: the quadratic
    term's t within its two-sided 99.5 % bound, both together 1 %), and the identity
    b' = b/(1+b), a' = a/(1+b) between the two lines, each difference with the jackknife error of
    the difference itself (the two lines come from the same members)."""
    profiles = {}
    for key in ("avalanche_by_ye", "avalanche_by_yi"):
        if key not in point or "member_mean" not in point[key]:
            fail_missing(path, f"{point.name}/{key}/member_mean")
        profiles[key] = Profile(point[key], -math.inf, math.inf)
    fits = {k: p.fit(2) for k, p in profiles.items()}
    if any(f is None for f in fits.values()):
        yield (f"{where}: Delta y is a straight line in y_e and y_i", NOT_JUDGED, "too few bins")
        return
    bound = t_quantile(profiles["avalanche_by_ye"].members - 1, Z9975)  # two lines: 1 % in all
    lines_ok = all(abs(top_t(f)) <= bound for f in fits.values())
    yield (f"{where}: Delta y is a straight line in y_e and y_i", lines_ok,
           ", ".join(f"{k} t of the quadratic term {top_t(f):.3g}" for k, f in fits.items())
           + f" (99.5 % bound {bound:.3g})")

    def identity(ye, yi):  # b' - b/(1+b), a' - a/(1+b) from the lines' coefficients
        a, b = ye[0], -ye[1]
        return np.array([-yi[1] - b / (1 + b), yi[0] - a / (1 + b)])

    line = lambda prof, m=None: np.polynomial.polynomial.polyfit(*prof.pooled(m), 1)
    ye, yi = profiles["avalanche_by_ye"], profiles["avalanche_by_yi"]
    if ye.members != yi.members:
        fail_missing(path, f"{point.name}: avalanche profiles of equal member counts")
    full = identity(line(ye), line(yi))
    loo = np.array([identity(line(ye, m), line(yi, m)) for m in range(ye.members)])
    err = jackknife(loo)
    for k, name in enumerate(("b'", "a'")):
        yield (f"{where}: {name} = {name[0]}/(1+b)", abs(full[k]) <= t95(ye.members) * err[k],
               f"{name} - {name[0]}/(1+b) = {full[k]:.3g} +- {err[k]:.2g} (jackknife of the "
               f"difference)")


def density_slope(group, low, high):
    """Slope of a density profile (`nu` or `nu_deposition`) over the strips in [low, high]:
    least squares through the members' mean, with the jackknife error over the members."""
    rows, centre = group["member_mean"][()], group["centre"][()]
    rows = rows[np.isfinite(rows).any(axis=1)]  # a failed member's row is NaN
    use = (centre >= low) & (centre <= high) & np.isfinite(rows).all(axis=0)
    x, rows = centre[use], rows[:, use]
    if x.size < 3 or len(rows) < 4:
        return None
    slope = lambda r: np.polynomial.polynomial.polyfit(x, r.mean(axis=0), 1)[1]
    loo = [slope(np.delete(rows, m, axis=0)) for m in range(len(rows))]
    return slope(rows), float(jackknife(loo)), x[0], x[-1], len(rows)


def predicted_density_claim(nu, where):
    """The final density predicted from the initial one (`nu/predicted`) against the measured
    nu(y): the deviation predicted - measured judged by its two lowest terms, its mean over the
    strips and its slope in y, each over its jackknife error (the program's `nu/deviation_terms`:
    the prediction refitted without each member as the measured density is averaged without it),
    Student's t with n - 1 degrees of freedom, each within its two-sided 99.5 % bound (both
    together within 1 %). A chi2 over the strips would count neighbouring strips, which share
    disks and move together, as independent."""
    claim = f"{where}: the final density predicted from the initial one matches"
    if "deviation_terms" not in nu:
        return (claim, NOT_JUDGED, "the file has no `nu/deviation_terms` (files from 2026-12-02 "
                "on; `loosepack analyse` adds them)")
    a = nu["deviation_terms"].attrs
    n = int(a["members"])
    full = np.array([float(a["mean"]), float(a["slope"])])
    err = np.array([float(a["mean_error"]), float(a["slope_error"])])
    if n < 4 or not np.all(np.isfinite(full)) or not np.all(err > 0):
        return claim, NOT_JUDGED, "too few strips or members (or no per-member rows)"
    t, bound = full / err, t_quantile(n - 1, Z9975)
    return (claim, bool(np.all(np.abs(t) <= bound)),
            f"deviation over {int(a['strips'])} strips ({float(a['from']):g}-{float(a['to']):g} "
            f"R): mean {full[0]:.3g} +- {err[0]:.2g} (t {t[0]:.3g}), slope {full[1]:.3g} +- "
            f"{err[1]:.2g} per R (t {t[1]:.3g}); 99.5 % bound {bound:.3g}, {n} members")


def collapse_density_claims(point, path, where):
    """Protocol C: flat nu_i(y) and nu_f(y) in the bulk, the final density predicted from the
    initial one, and dnu/nu_i below its upper limit nu_rcp/nu_i - 1."""
    a = point.attrs
    for name in ("nu/member_mean", "nu_deposition/member_mean", "members/top"):
        if name not in point:
            fail_missing(path, f"{point.name}/{name}")
    settings = point.file["settings"].attrs if "settings" in point.file else {}
    h = float(a["height"])
    low = float(a.get("lower_half_from", settings.get("lower_half_from", min(50.0, h / 4))))
    tops = point["members/top"][()]
    if "members/failure" in point:  # a failed member's top is where it stopped
        tops = tops[point["members/failure"][()] == 0]
    tops = tops[np.isfinite(tops) & (tops > 0)]
    final_top = float(tops.min()) if tops.size else h
    # The bulk: from at least a quarter of the height (a ballistic deposit is denser near the
    # floor and approaches its bulk density over tens of R, Lubachevsky, Privman and Roy 1993;
    # `lower_half_from` where a file sets it higher) up to half the deposit's height (its top
    # is rough over several R, where the density falls).
    for key, label, top in (("nu_deposition", "nu_i", h), ("nu", "nu_f", final_top)):
        r = density_slope(point[key], max(low, top / 4), top / 2)
        if r is None:
            yield (f"{where}: {label}(y) is flat in the bulk", NOT_JUDGED,
                   "too few strips or members")
            continue
        slope, err, lo, hi, members = r
        yield (f"{where}: {label}(y) is flat in the bulk", abs(slope) <= t95(members) * err,
               f"slope {slope:.3g} +- {err:.2g} per R over {lo:g}-{hi:g} R")
    if "predicted" in point["nu"]:
        yield predicted_density_claim(point["nu"], where)
    inc, inc_err = float(a["relative_increase_mean"]), float(a["relative_increase_sem"])
    inc_members = int(a.get("relative_increase_n", 0))
    nu_i = float(a["nu_initial_mean"])
    limit = RCP / nu_i - 1
    yield (f"{where}: dnu/nu_i stays below its limit nu_rcp/nu_i - 1",
           inc - t95(inc_members) * inc_err <= limit,
           f"dnu/nu_i = {inc:.3g} +- {inc_err:.2g}, limit {limit:.3g} (nu_i = {nu_i:.3g})")


def typical_size_claims(f):
    """A points that differ only in the Bond number (0 < Bo < inf, three or more): the typical
    avalanche size, mean |Delta y|, falls as Bo rises."""
    groups = {}
    for name in sorted(f["points"]):
        a = f["points"][name].attrs
        bo = float(a["bond_number"])
        if text(a["protocol"]) != "A" or not 0 < bo < math.inf or "mean_abs_dy_mean" not in a:
            continue
        groups.setdefault(same_system(a), []).append(
            (bo, float(a["mean_abs_dy_mean"]), float(a["mean_abs_dy_sem"]),
             int(a.get("mean_abs_dy_n", 0))))
    for key, pts in groups.items():
        if len(pts) < 3:
            continue
        pts.sort()
        box = dict(key)
        claim = (f"A across Bond numbers ({box['width']:g} x {box['height']:g}): the typical "
                 f"avalanche size mean |Delta y| falls as Bo rises")
        if any(n < 2 or not math.isfinite(e) for _, _, e, n in pts):
            yield (claim, NOT_JUDGED, "a point with fewer than two finished members: " +
                   ", ".join(f"Bo {bo:g}: {n}" for bo, _, _, n in pts))
            continue
        sig = lambda p, q: t95(min(p[3], q[3])) * math.hypot(p[2], q[2])
        falls = pts[0][1] - pts[-1][1] > sig(pts[0], pts[-1])
        no_rise = all(q[1] - p[1] <= sig(p, q) for p, q in zip(pts, pts[1:]))
        yield (claim, falls and no_rise,
               ", ".join(f"Bo {bo:g}: {m:.3g} +- {e:.2g} R" for bo, m, e, _ in pts))


def check_scan(f, path):
    """Yields (claim, ok, detail) for the fits across scan points that the file has."""
    if "analysis" not in f:
        fail_missing(path, "/analysis")
    a = f["analysis"]
    claims = (
        ("quadratic_vs_height", "A across heights: curvature c2 of Delta y(y_e) scales like 1/H",
         lambda p, e: p < -2 * e and abs(p + 1) <= 2 * e, "exponent p of c2 = A H^p"),
        ("slice_vs_height", "A across heights: the slice model's a stays fixed (Delta y = H f(y/H))",
         lambda p, e: abs(p) <= 2 * e, "exponent p of a = A H^p"),
        ("increase_vs_log_height", "C across heights: dnu/nu_i grows with ln H",
         lambda p, e: p > 2 * e, "slope against ln H"),
        ("increase_vs_nu_initial", "C across capture radii: dnu/nu_i falls with nu_i (power law)",
         lambda p, e: p < -2 * e, "exponent p of dnu/nu_i = A nu_i^p"),
    )
    yield from typical_size_claims(f)
    yield from deposition_fluctuation_order(f)
    for key, claim, holds, what in claims:
        if key not in a:  # a file written before this fit existed
            print(f"claims.py: {path}: no /analysis/{key} (an older file): `loosepack analyse "
                  f"{path}` adds it", file=sys.stderr)
            continue
        used = [f"points/{int(k):04d}" for k in a[key]["scan_points"][()]] \
            if "scan_points" in a[key] else []
        bos = sorted({float(f[u].attrs["bond_number"]) for u in used if u in f})
        through = f" (points {', '.join(u.split('/')[1] for u in used)}, Bo = " \
            f"{', '.join(f'{b:g}' for b in bos)})" if used else ""
        if not a[key].attrs.get("valid", 0):
            if used:  # tried through these points, but the fit did not settle
                yield (claim, NOT_JUDGED, f"no fit: it did not settle{through}")
            continue  # else the scan has no three points differing in that variable
        if claim.startswith("A ") and any(not 0 < b < math.inf for b in bos):
            yield (claim, NOT_JUDGED, f"the fit goes through points without cohesion{through}: "
                   f"`loosepack analyse {path}` fits the cohesive points")
            continue
        coef, err, attrs = fit(a[key], path)
        p, e = float(coef[1]), float(err[1])
        chi2, dof = float(attrs.get("chi2", math.nan)), float(attrs.get("dof", 0))
        # A law the points do not follow (chi2 above its 99 % quantile) holds nothing, however
        # wide the errors its scatter gives the exponent.
        acceptable = dof < 1 or not math.isfinite(chi2) or chi2 <= chi2_quantile99(dof)
        yield (claim, holds(p, e) and acceptable,
               f"{what} = {p:.3g} +- {e:.2g}, chi2/dof {float(attrs.get('reduced_chi2', math.nan)):.2g}"
               + ("" if acceptable else f" (the law rejected: chi2 above {chi2_quantile99(dof):.3g})")
               + through)


def main():
    if len(sys.argv) == 2 and sys.argv[1] in ("-h", "--help"):
        print(__doc__)
        sys.exit(0)
    if len(sys.argv) != 2 or sys.argv[1].startswith("-"):
        unusable("usage: claims.py RESULT.h5 (claims.py --help says what it checks)")
    path = sys.argv[1]
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        unusable(f"claims.py: {path}: not a readable HDF5 file ({e})")
    with f:
        check_result_file(f, path, "claims.py")
        for name in ("settings", "analysis"):  # read by the points' claims and the scan's
            if name in f:
                read_damaged_as_unusable(lambda: check_attributes(f[name]), path, name)
        results = []
        for name in sorted(f["points"]):
            point = f["points"][name]
            results.extend(read_damaged_as_unusable(
                lambda: check_attributes(point) or list(check_point(point, path)), path,
                f"points/{name}"))
        results.extend(read_damaged_as_unusable(lambda: list(check_scan(f, path)), path, "/"))
    if not results:
        print(f"claims.py: {path}: no scan point the claims speak about", file=sys.stderr)
        sys.exit(2)
    text, status = report(results)
    print(text)
    sys.exit(status)


def report(results):
    """The lines printed for (claim, ok, detail) verdicts, and the exit status: 1 when a claim
    fails, 2 when none could be judged, else 0."""
    lines = []
    for claim, ok, detail in results:
        verdict = "SKIP" if ok is NOT_JUDGED else "PASS" if ok else "FAIL"
        lines.append(f"{verdict}  {claim}  [{detail}]")
    judged = [ok for _, ok, _ in results if ok is not NOT_JUDGED]
    failed = sum(1 for ok in judged if not ok)
    skipped = len(results) - len(judged)
    lines.append(f"{len(judged) - failed} of {len(judged)} claims hold"
                 + (f"; {skipped} not judged (too little in the file)" if skipped else ""))
    return "\n".join(lines), 1 if failed else 0 if judged else 2


if __name__ == "__main__":
    main()
