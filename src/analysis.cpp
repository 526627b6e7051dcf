// Fits and theory checks on the aggregates of a scan (include/loosepack/analysis.hpp).
#include "loosepack/analysis.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>
#include <optional>
#include <set>
#include <tuple>
#include <utility>

namespace loosepack {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// A bin of an avalanche profile enters the fits with at least this many disks (and a finite,
// positive standard error, which needs at least two members).
constexpr double kMinBinCount = 10.0;

// Weighted linear least squares y ~ A c with standard errors sigma (empty: unit weights and
// errors from the residual scatter).
Fit linear_least_squares(const Eigen::MatrixXd& A, const Eigen::VectorXd& y,
                         const Eigen::VectorXd& sigma, bool weighted) {
  Fit f;
  const auto n = A.rows(), k = A.cols();
  f.points = static_cast<int>(n);
  f.dof = static_cast<int>(n - k);
  if (n < k || k == 0) {
    f.dof = -1;
    return f;
  }
  Eigen::VectorXd w =
      weighted ? Eigen::VectorXd(sigma.array().inverse()) : Eigen::VectorXd::Ones(n);
  const Eigen::MatrixXd Aw = w.asDiagonal() * A;
  const Eigen::VectorXd yw = w.asDiagonal() * y;
  // QR of the weighted design matrix, not the normal equations: a bin whose error is tiny
  // against the others' (disks that did not move at all) squares into a normal matrix too
  // ill-conditioned to solve, while the fit itself is well defined.
  if (!Aw.allFinite() || !yw.allFinite()) {
    f.dof = -1;
    return f;
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Aw);
  if (qr.rank() < k) {
    f.dof = -1;
    return f;
  }
  const Eigen::VectorXd c = qr.solve(yw);
  const Eigen::VectorXd r = yw - Aw * c;
  f.chi2 = r.squaredNorm();
  // (Aw^T Aw)^-1 = P R^-1 R^-T P^T
  const Eigen::MatrixXd R = qr.matrixR().topLeftCorner(k, k).triangularView<Eigen::Upper>();
  const Eigen::MatrixXd Rinv =
      R.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(k, k));
  Eigen::MatrixXd cov =
      qr.colsPermutation() * (Rinv * Rinv.transpose()) * qr.colsPermutation().transpose();
  if (!weighted) {
    cov *= f.dof > 0 ? f.chi2 / f.dof : kNaN;
  } else if (f.dof > 0 && f.chi2 / f.dof > 1.0) {
    cov *= f.chi2 / f.dof;
  }
  for (Eigen::Index j = 0; j < k; ++j) {
    f.coef.push_back(c(j));
    f.error.push_back(std::sqrt(std::max(0.0, cov(j, j))));
  }
  return f;
}

// Collects the usable points and fits y ~ sum_j basis_j(x) c_j.
Fit basis_fit(const std::vector<double>& x, const std::vector<double>& y,
              const std::vector<double>& sigma, int k,
              const std::function<double(double, int)>& basis) {
  const bool weighted = !sigma.empty();
  std::vector<std::size_t> use;
  for (std::size_t i = 0; i < x.size() && i < y.size(); ++i) {
    if (!std::isfinite(x[i]) || !std::isfinite(y[i])) continue;
    if (weighted && !(std::isfinite(sigma[i]) && sigma[i] > 0.0)) continue;
    use.push_back(i);
  }
  const auto n = static_cast<Eigen::Index>(use.size());
  Eigen::MatrixXd A(n, k);
  Eigen::VectorXd b(n), s(n);
  for (Eigen::Index r = 0; r < n; ++r) {
    const std::size_t i = use[static_cast<std::size_t>(r)];
    for (int j = 0; j < k; ++j) A(r, j) = basis(x[i], j);
    b(r) = y[i];
    s(r) = weighted ? sigma[i] : 1.0;
  }
  return linear_least_squares(A, b, s, weighted);
}

// The usable bins of an avalanche profile (their positions below x_max). Where the file has
// per-member rows, a bin is usable only if every member that did not fail has disks in it: above
// the lowest member's top, the pooled mean holds only the members that reach higher (after a
// collapse, those that collapsed less), and it bends away from every member's own profile.
std::vector<std::size_t> profile_bins(const BinnedStat& b, double x_max) {
  std::vector<std::size_t> out;
  for (std::size_t k = 0; k < b.centre.size(); ++k) {
    if (!(b.count[k] >= kMinBinCount && b.sem[k] > 0.0 && std::isfinite(b.mean[k]) &&
          b.position[k] <= x_max))
      continue;
    bool every_member = true;
    for (const auto& row : b.member_count) {
      if (row.size() != b.centre.size()) continue;  // malformed: ensemble_fit ignores the rows
      double samples = 0.0;
      for (double c : row) samples += c;
      every_member = every_member && (samples == 0.0 || row[k] > 0.0);  // 0: a failed member
    }
    if (every_member) out.push_back(k);
  }
  return out;
}

// Jackknife standard error of entry j of the replicas' vectors (one per member left out; NaN
// entries skipped): sqrt((n - 1)/n sum (v_j - mean v_j)^2).
double jackknife_error(const std::vector<std::vector<double>>& reps, std::size_t j) {
  double n = 0.0, mean = 0.0, ss = 0.0;
  for (const auto& v : reps)
    if (std::isfinite(v[j])) {
      n += 1.0;
      mean += v[j];
    }
  if (n < 2.0) return kNaN;
  mean /= n;
  for (const auto& v : reps)
    if (std::isfinite(v[j])) ss += (v[j] - mean) * (v[j] - mean);
  return std::sqrt((n - 1.0) / n * ss);
}

// chi2 of a fit's residuals, each against its own jackknife error over the members, so that a
// model that fits has chi2 distributed as chi2 with dof degrees of freedom:
// - an error estimated from n members makes z = residual / error follow Student's t with n - 1
//   degrees of freedom, whose tails are heavier than the normal's; each z is mapped to the
//   normal deviate of the same tail probability (chi2_term_of_t), so that each term is a chi2
//   of one degree of freedom in its tail as well as in its mean. With 3 or fewer members the
//   t's tails are too heavy to judge by (NaN).
// - each residual's own error already holds the fit's freedom (Var r_i = sigma^2 (1 - h_ii)), so
//   the sum of the terms has the expectation terms, not terms - params: it is scaled by
//   (terms - params) / terms.
// A residual whose error is zero (a bin every member fills alike) adds no term.
struct ResidualChi2 {
  std::vector<double> z;
  void add(double residual, double error) {
    if (error > 0.0) z.push_back(residual / error);
  }
  double value(double members, std::size_t params) const {
    const double p = static_cast<double>(params), t = static_cast<double>(z.size());
    if (!(members > 3.0) || !(t > p)) return kNaN;
    double sum = 0.0;
    for (double v : z) sum += chi2_term_of_t(v, members - 1.0);
    return sum * (t - p) / t;
  }
};

// An avalanche-profile fit Delta y = sum_j basis_j(y) c_j with ensemble errors. The coefficients
// come from an unweighted fit to the pooled bin means: weighting by the bins' standard errors
// lets the bins that barely move (the bottom at large Bond numbers, the crust), whose errors are
// near zero, pin the fit (docs/REPRODUCTION.md, "The weighted profile fits were biased"). The
// errors come from a jackknife over members: each member with samples is left out in turn, the
// pooled bin means and positions are recomputed without it, and the same bins are refitted;
// var c_j = (n - 1)/n sum_m (c_j(m) - mean c_j)^2. chi2 is that of the residuals of the bins
// against their jackknife errors (below). Without per-member rows (a file of an older program)
// the errors come from the residual scatter and chi2 is against the bins' standard errors.
Fit ensemble_fit(const BinnedStat& b, double x_max, int k,
                 const std::function<double(double, int)>& basis) {
  const std::vector<std::size_t> bins = profile_bins(b, x_max);
  std::vector<double> x, y;
  for (std::size_t u : bins) {
    x.push_back(b.position[u]);
    y.push_back(b.mean[u]);
  }
  Fit f = basis_fit(x, y, {}, k, basis);
  if (!f.valid()) return f;
  auto residual = [&](const std::vector<double>& c, double xv, double yv) {
    double m = 0.0;
    for (int j = 0; j < k; ++j) m += c[static_cast<std::size_t>(j)] * basis(xv, j);
    return yv - m;
  };
  // Without per-member rows: chi2 against the bins' standard errors.
  f.chi2 = 0.0;
  for (std::size_t u : bins) {
    const double z = residual(f.coef, b.position[u], b.mean[u]) / b.sem[u];
    f.chi2 += z * z;
  }
  const std::size_t n_bins = b.centre.size();
  auto row_ok = [&](const std::vector<double>& r) { return r.size() == n_bins; };
  std::vector<std::vector<double>> coefs, residuals;  // per replica; residuals per bin of `bins`
  for (std::size_t m = 0; m < b.member_count.size(); ++m) {
    const auto& mc = b.member_count[m];
    if (!row_ok(mc) || m >= b.member_mean.size() || !row_ok(b.member_mean[m]) ||
        m >= b.member_position.size() || !row_ok(b.member_position[m]))
      return f;  // malformed rows: keep the residual-scatter errors
    double samples = 0.0;
    for (double c : mc) samples += c;
    if (!(samples > 0.0)) continue;  // a failed member: not in the pooled means
    std::vector<double> xr, yr;
    std::vector<std::size_t> used;  // index into `bins`
    for (std::size_t i = 0; i < bins.size(); ++i) {
      const std::size_t u = bins[i];
      const double c = mc[u], rest = b.count[u] - c;
      if (!(rest > 0.0)) continue;
      used.push_back(i);
      xr.push_back(c > 0.0 ? (b.position[u] * b.count[u] - b.member_position[m][u] * c) / rest
                           : b.position[u]);
      yr.push_back(c > 0.0 ? (b.mean[u] * b.count[u] - b.member_mean[m][u] * c) / rest : b.mean[u]);
    }
    const Fit r = basis_fit(xr, yr, {}, k, basis);
    if (!r.valid()) {  // a member without whom the bins do not determine the fit
      std::fill(f.error.begin(), f.error.end(), kNaN);
      f.chi2 = kNaN;
      return f;
    }
    coefs.push_back(r.coef);
    std::vector<double> res(bins.size(), kNaN);
    for (std::size_t i = 0; i < used.size(); ++i) res[used[i]] = residual(r.coef, xr[i], yr[i]);
    residuals.push_back(std::move(res));
  }
  if (coefs.size() < 2) return f;
  const auto n = static_cast<double>(coefs.size());
  for (std::size_t j = 0; j < f.coef.size(); ++j) f.error[j] = jackknife_error(coefs, j);
  f.replicas = coefs;
  // chi2 of the residuals against their own jackknife errors. The bins' standard errors are
  // strongly correlated (a member that moved more moved more in every bin), so chi2 against
  // them says little; the residuals' errors have the fitted common modes taken out.
  ResidualChi2 chi2;
  for (std::size_t i = 0; i < bins.size(); ++i)
    chi2.add(residual(f.coef, b.position[bins[i]], b.mean[bins[i]]), jackknife_error(residuals, i));
  f.chi2 = chi2.value(n, f.coef.size());
  return f;
}

double power(double v, int j) { return std::pow(v, j); }

// The collapse identity's differences b' - b/(1+b), a' - a/(1+b) from the two lines, and their
// jackknife errors from the lines' replicas (the same members left out of both).
void identity_differences(PointAnalysis& a) {
  auto differences = [](const std::vector<double>& ye, const std::vector<double>& yi) {
    const double b = -ye[1];
    return std::array<double, 2>{-yi[1] - b / (1.0 + b), yi[0] - ye[0] / (1.0 + b)};
  };
  const auto full = differences(a.dy_by_ye.coef, a.dy_by_yi.coef);
  a.b_prime_difference = full[0];
  a.a_prime_difference = full[1];
  a.b_prime_difference_error = a.a_prime_difference_error = kNaN;
  const auto& re = a.dy_by_ye.replicas;
  const auto& ri = a.dy_by_yi.replicas;
  if (re.size() != ri.size() || re.size() < 2) return;
  std::vector<std::vector<double>> reps;
  for (std::size_t m = 0; m < re.size(); ++m) {
    const auto d = differences(re[m], ri[m]);
    reps.push_back({d[0], d[1]});
  }
  a.b_prime_difference_error = jackknife_error(reps, 0);
  a.a_prime_difference_error = jackknife_error(reps, 1);
}

std::function<double(double, int)> slice_basis(double H) {
  return [H](double y, int) { return -y * (1.0 - y / H); };
}

double coef(const Fit& f, std::size_t k) { return k < f.coef.size() ? f.coef[k] : 0.0; }
double err(const Fit& f, std::size_t k) { return k < f.error.size() ? f.error[k] : kNaN; }

// A polynomial profile fit of `degree`, with the t of the term it lacks from the fit one degree
// higher (where that fit has errors from the members).
Fit profile_fit(const BinnedStat& b, int degree) {
  constexpr double kAll = std::numeric_limits<double>::infinity();
  Fit f = ensemble_fit(b, kAll, degree + 1, power);
  const Fit next = ensemble_fit(b, kAll, degree + 2, power);
  const auto k = static_cast<std::size_t>(degree + 1);
  if (f.valid() && next.valid() && !next.replicas.empty())
    f.next_term_t = coef(next, k) / err(next, k);
  return f;
}

// The scan parameter a fit across points varies.
enum class Varying { Height, CaptureRadius };

double value_of(const SystemParams& p, Varying v) {
  return v == Varying::Height ? p.height : p.capture_radius;
}

// Points of `protocol` that agree in every parameter but the varying one: the group with the
// most distinct values of it; empty unless that is at least three.
std::vector<std::size_t> group_varying(const std::vector<PointResult>& points, Protocol protocol,
                                       Varying varying) {
  auto same_except = [&](const SystemParams& a, SystemParams b) {
    if (varying == Varying::Height) b.height = a.height;
    if (varying == Varying::CaptureRadius) b.capture_radius = a.capture_radius;
    return a == b;  // every other parameter (the disks' density and radius, gravity too)
  };
  // The points that share everything else with `ref`, and how many values of the variable
  // they hold.
  auto group_of = [&](const SystemParams& ref) {
    std::vector<std::size_t> group;
    std::vector<double> distinct;
    for (std::size_t k = 0; k < points.size(); ++k) {
      if (points[k].point.protocol != protocol || !same_except(ref, points[k].point.params))
        continue;
      group.push_back(k);
      const double v = value_of(points[k].point.params, varying);
      if (std::find(distinct.begin(), distinct.end(), v) == distinct.end()) distinct.push_back(v);
    }
    return std::make_pair(group, distinct.size());
  };
  // The group with the most values (the first such), so that a scan that varies the height in
  // some points and the capture radius in others gets both fits. Protocol A's laws across
  // heights are those of cohesive avalanches: points at Bo = 0 or inf form no group.
  const auto cohesive = [](const SystemParams& p) {
    return p.bond_number > 0.0 && std::isfinite(p.bond_number);
  };
  std::vector<std::size_t> out;
  std::size_t most = 0;
  for (const auto& p : points) {
    if (p.point.protocol != protocol) continue;
    if (protocol == Protocol::A && !cohesive(p.point.params)) continue;
    auto [group, values] = group_of(p.point.params);
    if (values > most) {
      most = values;
      out = std::move(group);
    }
  }
  if (most < 3) out.clear();
  return out;
}

// One datum of a fit across points: x, y, y's standard error and the number of members that
// error comes from (their scatter or a jackknife over them); where x is measured on the same
// members too, x's standard error and the covariance of the two means.
struct Datum {
  double x, y, sigma;
  std::size_t members;
  double sigma_x = 0.0, cov = 0.0;
};
// The members behind a profile fit's jackknife errors; a fit without replicas (a file without
// per-member rows) has its errors from the residuals' scatter over many bins instead, which
// `across_points` need not widen.
std::size_t jackknife_members(const Fit& f) {
  return f.replicas.empty() ? std::numeric_limits<std::size_t>::max() : f.replicas.size();
}
std::optional<Datum> keep_if(bool usable, const Datum& d) {
  return usable ? std::optional<Datum>(d) : std::nullopt;
}

// The fit `fit(x, y, sigma, sigma_x, cov)` over the points of `protocol` that differ only in
// `varying` (group_varying) and have a datum (`datum(k)` for point k); the fit keeps their
// indices.
// A standard error estimated from n members is itself uncertain: a datum's (y - model) / sigma
// then follows Student's t with n - 1 degrees of freedom, of variance (n - 1)/(n - 3), and chi2
// against the estimated errors has that factor in its expectation. Each sigma is widened by the
// t's spread, sqrt((n - 1)/(n - 3)) (sigma_x too, cov by its square), so that a law the points
// follow has chi2/dof near 1 and the coefficients' errors hold the errors' own uncertainty. With 3
// or fewer members behind a datum that spread is unbounded: the fit keeps the errors as estimated
// and has no chi2 (NaN), so that nothing judges the law by it.
template <class FitFn, class DatumFn>
Fit across_points(const std::vector<PointResult>& points, Protocol protocol, Varying varying,
                  FitFn fit, DatumFn datum) {
  std::vector<double> x, y, sigma, sigma_x, cov;
  std::vector<int> used;
  bool few_members = false;
  for (std::size_t k : group_varying(points, protocol, varying)) {
    const std::optional<Datum> d = datum(k);
    // A datum without an error (one member finished; x's error or the covariance not defined)
    // the fit could not weigh: it takes no part, neither in scan_points nor in whether chi2 is
    // judged.
    if (!d || !(std::isfinite(d->sigma) && d->sigma > 0.0) || !std::isfinite(d->sigma_x) ||
        !std::isfinite(d->cov))
      continue;
    const double n = static_cast<double>(d->members);
    few_members = few_members || n <= 3.0;
    x.push_back(d->x);
    y.push_back(d->y);
    const double widen = n > 3.0 ? (n - 1.0) / (n - 3.0) : 1.0;
    sigma.push_back(d->sigma * std::sqrt(widen));
    sigma_x.push_back(d->sigma_x * std::sqrt(widen));
    cov.push_back(d->cov * widen);
    used.push_back(points[k].point.index);  // K of points/K, not the position among those held
  }
  // A law through fewer than three values of the varying parameter has no degree of freedom
  // left to be tested by (group_varying asks for three; a datum may have dropped out): no fit.
  if (std::set<double>(x.begin(), x.end()).size() < 3) return Fit{};
  // A fit that fails there (the effective variance's iteration did not settle) keeps the points
  // it was tried through, so that readers say which law was not fitted instead of nothing.
  Fit f = fit(x, y, sigma, sigma_x, cov);
  f.scan_points = std::move(used);
  if (f.valid() && few_members) f.chi2 = kNaN;
  return f;
}

}  // namespace

double Fit::reduced_chi2() const { return dof > 0 ? chi2 / dof : kNaN; }

Fit polynomial_fit(const std::vector<double>& x, const std::vector<double>& y,
                   const std::vector<double>& sigma, int degree) {
  return basis_fit(x, y, sigma, degree + 1, power);
}

double polynomial(const Fit& f, double x) {
  double v = 0.0, p = 1.0;
  for (double c : f.coef) {
    v += c * p;
    p *= x;
  }
  return v;
}

namespace {

// Power-law data on log axes: ln x, ln y and the errors relative to x and y (those of the
// logarithms to first order), the covariance over x y. A point with x or y not positive, or (with
// x errors) an x error or covariance that is not finite, is left out, and so are the points past
// the end of a shorter vector that is given; absent errors stay absent.
struct LogAxes {
  std::vector<double> x, y, sigma, sigma_x, cov;
};
LogAxes on_log_axes(const std::vector<double>& x, const std::vector<double>& y,
                    const std::vector<double>& sigma, const std::vector<double>& sigma_x = {},
                    const std::vector<double>& cov = {}) {
  LogAxes out;
  const bool with_x = !sigma_x.empty() && !cov.empty();
  std::size_t n = std::min(x.size(), y.size());
  if (!sigma.empty()) n = std::min(n, sigma.size());
  if (with_x) n = std::min({n, sigma_x.size(), cov.size()});
  for (std::size_t i = 0; i < n; ++i) {
    if (!(x[i] > 0.0) || !(y[i] > 0.0)) continue;
    if (with_x && (!std::isfinite(sigma_x[i]) || !std::isfinite(cov[i]))) continue;
    out.x.push_back(std::log(x[i]));
    out.y.push_back(std::log(y[i]));
    if (!sigma.empty()) out.sigma.push_back(sigma[i] / y[i]);
    if (with_x) {
      out.sigma_x.push_back(sigma_x[i] / x[i]);
      out.cov.push_back(cov[i] / (x[i] * y[i]));
    }
  }
  return out;
}

}  // namespace

Fit power_law_fit(const std::vector<double>& x, const std::vector<double>& y,
                  const std::vector<double>& sigma) {
  const LogAxes l = on_log_axes(x, y, sigma);
  return polynomial_fit(l.x, l.y, l.sigma, 1);
}

Fit power_law_fit(const std::vector<double>& x, const std::vector<double>& y,
                  const std::vector<double>& sigma, const std::vector<double>& sigma_x,
                  const std::vector<double>& cov) {
  constexpr int kIterations = 100;
  constexpr double kSettled = 1e-12;
  if (sigma.empty() || sigma_x.empty() || cov.empty()) return Fit{};
  const LogAxes l = on_log_axes(x, y, sigma, sigma_x, cov);
  Fit f = polynomial_fit(l.x, l.y, l.sigma, 1);
  for (int it = 0; it < kIterations && f.valid(); ++it) {
    const double p = f.coef[1];
    std::vector<double> effective(l.x.size());
    for (std::size_t i = 0; i < l.x.size(); ++i) {
      const double sy = l.sigma[i], sx = l.sigma_x[i];
      const double var = sy * sy + p * p * sx * sx - 2.0 * p * l.cov[i];
      effective[i] = var > 0.0 ? std::sqrt(var) : kNaN;  // NaN: skipped by the fit
    }
    f = polynomial_fit(l.x, l.y, effective, 1);
    if (f.valid() && std::fabs(f.coef[1] - p) <= kSettled * (1.0 + std::fabs(p))) return f;
  }
  return Fit{};
}

double chi2_term_of_t(double t, double nu) {
  const double c = (8.0 * nu + 1.0) / (8.0 * nu + 3.0);
  return c * c * nu * std::log1p(t * t / nu);
}

double chi2_quantile99(double dof) {
  constexpr double kZ99 = 2.3263;  // the standard normal's 99 % quantile
  const double a = 2.0 / (9.0 * dof);
  return dof * std::pow(1.0 - a + kZ99 * std::sqrt(a), 3);
}

namespace {

// ln n = polynomial of `degree` in x, fitted to the counts n as Poisson's by maximum likelihood
// (iteratively reweighted least squares, a step halved while it lowers the likelihood), empty
// bins included. A least-squares fit of ln n weighted by n over the bins with disks is biased
// where counts are small: a count that fluctuated up weighs more than one that fluctuated down,
// and an empty bin drops out, so a tail's last bins bend ln n upwards. The maximum lies at finite
// coefficients only where more bins than `degree` hold counts (else a polynomial that vanishes on
// them drives the empty bins' expectations to zero): an invalid fit there, and where the
// iterations do not settle. Errors and chi2 are those of the last weighted step: the inverse of
// the Fisher information, widened by Pearson's chi2 per degree of freedom where that exceeds one,
// and Pearson's chi2 of the counts against the model.
Fit log_count_fit(const std::vector<double>& x, const std::vector<double>& n, int degree) {
  constexpr int kIterations = 100, kHalvings = 40;
  constexpr double kSettled = 1e-10;  // the largest change of ln mu in a step
  if (std::count_if(n.begin(), n.end(), [](double c) { return c > 0.0; }) <= degree) return Fit{};
  const std::size_t bins = x.size();
  std::vector<double> z(bins), sigma(bins), eta(bins);
  for (std::size_t k = 0; k < bins; ++k) {  // start: ln(n + 1/2), weights n + 1/2
    z[k] = std::log(n[k] + 0.5);
    sigma[k] = 1.0 / std::sqrt(n[k] + 0.5);
  }
  Fit f = polynomial_fit(x, z, sigma, degree);
  auto log_likelihood = [&](const Fit& g, std::vector<double>& e) {
    double l = 0.0;
    for (std::size_t k = 0; k < bins; ++k) {
      e[k] = polynomial(g, x[k]);
      l += n[k] * e[k] - std::exp(e[k]);
    }
    return l;
  };
  if (!f.valid()) return Fit{};
  double l = log_likelihood(f, eta);
  std::vector<double> next_eta(bins);
  for (int it = 0; it < kIterations; ++it) {
    for (std::size_t k = 0; k < bins; ++k) {
      const double mu = std::exp(eta[k]);
      z[k] = eta[k] + (n[k] - mu) / mu;
      sigma[k] = 1.0 / std::sqrt(mu);
    }
    Fit next = polynomial_fit(x, z, sigma, degree);
    if (!next.valid() || next.points != static_cast<int>(bins)) return Fit{};
    double next_l = log_likelihood(next, next_eta);
    for (int h = 0; h < kHalvings && !(next_l >= l); ++h) {
      for (std::size_t j = 0; j < next.coef.size(); ++j)
        next.coef[j] = 0.5 * (next.coef[j] + f.coef[j]);
      next_l = log_likelihood(next, next_eta);
    }
    double change = 0.0;
    for (std::size_t k = 0; k < bins; ++k)
      change = std::max(change, std::fabs(next_eta[k] - eta[k]));
    f = std::move(next);
    eta.swap(next_eta);
    l = next_l;
    if (change < kSettled) return f;
  }
  return Fit{};
}

// The histogram fit's chi2 and errors from the members' scatter (HistogramShape): each member
// with disks left out in turn, the rest's counts scaled to the whole ensemble's and refitted;
// errors the jackknife of the coefficients, chi2 the residuals against their jackknife errors.
// Leaves `f` unchanged (Pearson's chi2) and returns false with fewer than 4 members that did not
// fail: those whose `member_failure` is 0 or, where it does not give one per row, the rows with
// disks (a failed member's row is 0; a member that finished may have none in the cut band).
bool member_scatter(Fit& f, int degree, const std::vector<double>& x, const std::vector<double>& n,
                    const std::vector<std::size_t>& bins,
                    const std::vector<std::vector<double>>& member_counts,
                    const std::vector<double>& member_failure) {
  const bool flagged = member_failure.size() == member_counts.size();
  std::vector<const std::vector<double>*> rows;
  for (std::size_t k = 0; k < member_counts.size(); ++k) {
    double samples = 0.0;
    for (double c : member_counts[k]) samples += c;
    if (flagged ? member_failure[k] == 0.0 : samples > 0.0) rows.push_back(&member_counts[k]);
  }
  const auto m = static_cast<double>(rows.size());
  if (rows.size() < 4 || !f.valid()) return false;
  std::vector<std::vector<double>> coefs, residuals;
  for (const auto* row : rows) {
    std::vector<double> rest;
    for (std::size_t i = 0; i < bins.size(); ++i)
      rest.push_back((n[i] - (*row)[bins[i]]) * m / (m - 1.0));
    const Fit r = log_count_fit(x, rest, degree);
    if (!r.valid() || r.coef.size() != f.coef.size()) {
      // A member without whom the bins do not determine the fit: no errors from the members'
      // scatter (as ensemble_fit), where Poisson's would pass for them.
      f.chi2 = kNaN;
      std::fill(f.error.begin(), f.error.end(), kNaN);
      return true;
    }
    std::vector<double> res;
    for (std::size_t i = 0; i < bins.size(); ++i)
      res.push_back(rest[i] - std::exp(polynomial(r, x[i])));
    coefs.push_back(r.coef);
    residuals.push_back(std::move(res));
  }
  for (std::size_t j = 0; j < f.coef.size(); ++j) f.error[j] = jackknife_error(coefs, j);
  f.replicas = coefs;
  ResidualChi2 chi2;  // as ensemble_fit's
  for (std::size_t i = 0; i < bins.size(); ++i)
    chi2.add(n[i] - std::exp(polynomial(f, x[i])), jackknife_error(residuals, i));
  f.chi2 = chi2.value(m, f.coef.size());
  return true;
}

// The band of a histogram's bins the shapes are fitted to: from the bin that holds the counts'
// kShapeTail quantile to the one that holds their 1 - kShapeTail quantile, empty bins within
// included. Beyond it the few disks of a tail are one or two members' avalanches, bins of
// single lumps, which no smooth ln n describes and which make the jackknife of the shapes' next
// terms heavy-tailed (a member whose absence empties them moves the top coefficients far).
constexpr double kShapeTail = 0.005;
std::vector<std::size_t> shape_bins(const std::vector<double>& counts, std::size_t bins) {
  double total = 0.0;
  for (std::size_t k = 0; k < bins; ++k) total += counts[k] > 0.0 ? counts[k] : 0.0;
  std::vector<std::size_t> out;
  double below = 0.0;
  for (std::size_t k = 0; k < bins && total > 0.0; ++k) {
    below += counts[k] > 0.0 ? counts[k] : 0.0;
    if (!out.empty() || below > kShapeTail * total) out.push_back(k);
    if (below >= (1.0 - kShapeTail) * total) break;
  }
  return out;
}

// The two-sided bound on each of a shape's next two terms' t: each at 0.5 %, so that a right
// shape fails either in at most 1 % of ensembles, as the chi2 test's 99 % quantile would have it.
// Compared as chi2 terms (chi2_term_of_t), so that one bound serves every number of members:
// the square of the standard normal's 99.75 % quantile, 2.807.
constexpr double kTermBound = 2.807 * 2.807;

// The shapes' next two terms, from the fits of degrees 2 to 4 with the members' jackknife:
// the exponential's are the quadratic (which chooses between the shapes) and the cubic, the
// Gaussian's the cubic and the quartic. Returns whether either shape had its errors from the
// members (false: fewer than 4 members that did not fail).
bool member_terms(HistogramShape& h, const std::vector<double>& x, const std::vector<double>& n,
                  const std::vector<std::size_t>& bins,
                  const std::vector<std::vector<double>>& member_counts,
                  const std::vector<double>& member_failure) {
  const bool exp_scatter =
      member_scatter(h.exponential, 1, x, n, bins, member_counts, member_failure);
  const bool gauss_scatter =
      member_scatter(h.gaussian, 2, x, n, bins, member_counts, member_failure);
  auto higher = [&](int degree) {
    Fit f = log_count_fit(x, n, degree);
    if (f.valid() && f.dof > 0)
      member_scatter(f, degree, x, n, bins, member_counts, member_failure);
    return f;
  };
  const Fit cubic = higher(3), quartic = higher(4);
  auto top_term_t = [](const Fit& next) {
    if (!next.valid() || next.replicas.size() < 4) return kNaN;
    const std::size_t k = next.coef.size() - 1;
    return coef(next, k) / err(next, k);
  };
  h.exponential.next_term_t = top_term_t(h.gaussian);
  h.exponential.second_term_t = top_term_t(cubic);
  h.gaussian.next_term_t = top_term_t(cubic);
  h.gaussian.second_term_t = top_term_t(quartic);
  return exp_scatter || gauss_scatter;
}

// The verdict with errors from the members: Akaike's criterion chooses, the quadratic term's
// share of chi2 from its t; the chosen shape must hold, both of its next two terms within their
// bound (a Gaussian with a maximum, c2 < 0), else "neither".
void verdict_by_terms(HistogramShape& h) {
  const auto members = static_cast<double>(h.gaussian.replicas.size());
  if (members < 4.0) {  // a member without whom the bins fit no Gaussian: no t to choose by
    h.preferred = "neither";
    return;
  }
  auto term = [&](double t) { return chi2_term_of_t(t, members - 1.0); };
  auto holds = [&](const Fit& f) {
    return term(f.next_term_t) <= kTermBound && term(f.second_term_t) <= kTermBound;
  };
  h.quadratic_chi2 = term(h.exponential.next_term_t);
  h.exponential_acceptable = holds(h.exponential);
  h.gaussian_acceptable = coef(h.gaussian, 2) < 0.0 && holds(h.gaussian);
  if (h.quadratic_chi2 <= 2.0 && h.exponential_acceptable)
    h.preferred = "exponential";
  else if (h.quadratic_chi2 > 2.0 && h.gaussian_acceptable)
    h.preferred = "gaussian";
  else
    h.preferred = "neither";
}

// The verdict without the members' counts: Akaike's criterion on Pearson's chi2, and the chosen
// shape must fit, its chi2 within the 99 % quantile (a Gaussian with a maximum).
void verdict_by_pearson(HistogramShape& h) {
  auto fits = [](const Fit& f) { return f.chi2 <= chi2_quantile99(f.dof); };
  h.exponential_acceptable = fits(h.exponential);
  h.gaussian_acceptable = coef(h.gaussian, 2) < 0.0 && fits(h.gaussian);
  const bool exponential_first = h.exponential.chi2 + 2.0 * 2.0 <= h.gaussian.chi2 + 2.0 * 3.0;
  if (exponential_first)
    h.preferred = h.exponential_acceptable ? "exponential" : "neither";
  else
    h.preferred = h.gaussian_acceptable ? "gaussian" : "neither";
}

}  // namespace

HistogramShape histogram_shape(const std::vector<double>& edges, const std::vector<double>& counts,
                               const std::vector<std::vector<double>>& member_counts,
                               const std::vector<double>& member_failure) {
  HistogramShape h;
  h.preferred = "none";
  const std::size_t n_bins = std::min(counts.size(), edges.empty() ? 0 : edges.size() - 1);
  const std::vector<std::size_t> bins = shape_bins(counts, n_bins);
  std::vector<double> x, n;
  for (std::size_t k : bins) {
    x.push_back(0.5 * (edges[k] + edges[k + 1]));
    n.push_back(counts[k]);
  }
  h.exponential = log_count_fit(x, n, 1);
  h.gaussian = log_count_fit(x, n, 2);
  bool rows_ok = !member_counts.empty();
  for (const auto& row : member_counts) rows_ok = rows_ok && row.size() == counts.size();
  if (rows_ok) h.member_errors = member_terms(h, x, n, bins, member_counts, member_failure);
  const double beta = coef(h.exponential, 1);
  h.decay_length = beta < 0.0 ? -1.0 / beta : kNaN;
  const double g = coef(h.gaussian, 2);
  h.gaussian_mean = g < 0.0 ? -coef(h.gaussian, 1) / (2.0 * g) : kNaN;
  h.gaussian_width = g < 0.0 ? std::sqrt(-1.0 / (2.0 * g)) : kNaN;
  // Both shapes and the Gaussian's next terms need bins: six for the quartic and a degree of
  // freedom, where the members give errors.
  const bool enough_bins = h.member_errors ? x.size() >= 6 : h.gaussian.dof > 0;
  if (!h.exponential.valid() || !h.gaussian.valid() || !enough_bins) return h;
  if (h.member_errors)
    verdict_by_terms(h);
  else
    verdict_by_pearson(h);
  return h;
}

namespace {

// Protocol C's identities: b' = b / (1 + b) and a' = a / (1 + b) from the fits of Delta y
// against y_e and y_i (docs/MODEL.md, "Theory evaluated on the results").
void add_identities(PointAnalysis& a) {
  const double b = -coef(a.dy_by_ye, 1), sb = err(a.dy_by_ye, 1);
  const double ae = coef(a.dy_by_ye, 0), sa = err(a.dy_by_ye, 0);
  a.b_prime = -coef(a.dy_by_yi, 1);
  a.b_prime_error = err(a.dy_by_yi, 1);
  a.a_prime = coef(a.dy_by_yi, 0);
  a.a_prime_error = err(a.dy_by_yi, 0);
  a.b_prime_predicted = b / (1.0 + b);
  a.b_prime_predicted_error = sb / ((1.0 + b) * (1.0 + b));
  a.a_prime_predicted = ae / (1.0 + b);
  // a and b come from one fit and are correlated (a collapse that compresses more lowers both):
  // the jackknife of a / (1 + b) over the fit's replicas, where it has them; else first-order
  // propagation as if they were independent (a file without per-member rows).
  std::vector<std::vector<double>> ratio;
  for (const auto& r : a.dy_by_ye.replicas) ratio.push_back({r[0] / (1.0 - r[1])});
  a.a_prime_predicted_error = ratio.size() >= 2
                                  ? jackknife_error(ratio, 0)
                                  : std::hypot(sa / (1.0 + b), ae * sb / ((1.0 + b) * (1.0 + b)));
  a.slope_increase = b;
  a.slope_increase_error = sb;
  identity_differences(a);
}

// The deposition density's power law nu_d = A y_i^p, fitted over the strips from lower_half_from
// to 1.5 strips below H (weights their standard errors); `x` gets the strips' centres.
Fit deposition_law(const EnsembleProfile& nu_d, double from, double H, double strip,
                   std::vector<double>& x) {
  std::vector<double> y, s;
  x.clear();
  for (std::size_t k = 0; k < nu_d.centre.size(); ++k) {
    const double c = nu_d.centre[k];
    if (c < from || c + 1.5 * strip > H) continue;
    x.push_back(c);
    y.push_back(nu_d.mean[k]);
    s.push_back(nu_d.sem[k]);
  }
  return power_law_fit(x, y, s);
}

// nu_d(y_i(y_e)) (1 - dDelta y/dy_e) at the strips' centres y_e within [y_lo, y_hi] whose y_i
// lies in [x_lo, x_hi], from the power law and the coefficients of Delta y(y_e); NaN elsewhere.
std::vector<double> predicted_density(const std::vector<double>& centre, const Fit& law,
                                      const std::vector<double>& dy, double y_lo, double y_hi,
                                      double x_lo, double x_hi) {
  std::vector<double> out(centre.size(), kNaN);
  const double lnA = coef(law, 0), p = coef(law, 1);
  for (std::size_t k = 0; k < centre.size(); ++k) {
    const double ye = centre[k];
    if (ye < y_lo || ye > y_hi) continue;
    double shift = 0.0, slope = 0.0;
    for (std::size_t j = 0; j < dy.size(); ++j) {
      shift += dy[j] * std::pow(ye, static_cast<double>(j));
      if (j > 0) slope += static_cast<double>(j) * dy[j] * std::pow(ye, j - 1.0);
    }
    const double yi = ye - shift;
    if (yi < x_lo || yi > x_hi) continue;
    out[k] = std::exp(lnA) * std::pow(yi, p) * (1.0 - slope);
  }
  return out;
}

// The mean over the strips `use` of the deviation and its least-squares slope in y.
std::pair<double, double> deviation_terms(const std::vector<double>& centre,
                                          const std::vector<double>& predicted,
                                          const std::vector<double>& measured,
                                          const std::vector<std::size_t>& use) {
  double sx = 0.0, sd = 0.0;
  for (std::size_t k : use) {
    sx += centre[k];
    sd += predicted[k] - measured[k];
  }
  const double n = static_cast<double>(use.size()), mx = sx / n, md = sd / n;
  double sxx = 0.0, sxd = 0.0;
  for (std::size_t k : use) {
    sxx += (centre[k] - mx) * (centre[k] - mx);
    sxd += (centre[k] - mx) * (predicted[k] - measured[k] - md);
  }
  return {md, sxx > 0.0 ? sxd / sxx : kNaN};
}

// The deviation's terms (PointAnalysis::DeviationTerms) with their jackknife over the members
// that did not fail: each left out of the deposition density, of Delta y(y_e) (its fit's
// replica) and of the measured density in turn.
void add_deviation_terms(const PointResult& pr, const ObservableSettings& obs, double x_lo,
                         double x_hi, double y_lo, double y_hi, PointAnalysis& a) {
  const double H = pr.point.params.height;
  std::vector<std::size_t> ok;  // the members that did not fail, in member order
  double top = kNaN;
  for (std::size_t m = 0; m < pr.m_failure.size(); ++m)
    if (pr.m_failure[m] == 0.0) {
      ok.push_back(m);
      top = std::isnan(top) ? pr.m_top[m] : std::min(top, pr.m_top[m]);
    }
  const auto& reps = a.dy_by_ye.replicas;
  if (ok.size() < 4 || reps.size() != ok.size() ||
      pr.nu_member_rows.size() != pr.m_failure.size() ||
      pr.nu_deposition_member_rows.size() != pr.m_failure.size())
    return;
  const std::vector<double>& centre = pr.nu.centre;
  std::vector<std::vector<double>> predicted, measured;  // per member left out
  for (std::size_t r = 0; r < ok.size(); ++r) {
    auto without = [&](const std::vector<std::vector<double>>& rows) {
      std::vector<std::vector<double>> rest;
      for (std::size_t m = 0; m < rows.size(); ++m)
        if (m != ok[r]) rest.push_back(rows[m]);  // a failed member's row is NaN: not counted
      return rest;
    };
    std::vector<double> x;
    const Fit law =
        deposition_law(ensemble(without(pr.nu_deposition_member_rows), pr.nu_deposition.centre),
                       obs.lower_half_from_at(H), H, obs.strip_width, x);
    if (!law.valid()) return;
    predicted.push_back(predicted_density(centre, law, reps[r], y_lo, y_hi, x_lo, x_hi));
    measured.push_back(ensemble(without(pr.nu_member_rows), centre).mean);
  }
  auto& t = a.nu_deviation_terms;
  const double to = top - obs.cut_top_at(H);
  std::vector<std::size_t> use;
  for (std::size_t k = 0; k < centre.size(); ++k) {
    bool finite = std::isfinite(a.nu_deviation[k]);
    for (std::size_t r = 0; r < ok.size(); ++r)
      finite = finite && std::isfinite(predicted[r][k] - measured[r][k]);
    if (finite && centre[k] >= obs.lower_half_from_at(H) && centre[k] <= to) use.push_back(k);
  }
  if (use.size() < 3) return;
  std::vector<std::vector<double>> terms;
  for (std::size_t r = 0; r < ok.size(); ++r) {
    const auto [mean, slope] = deviation_terms(centre, predicted[r], measured[r], use);
    terms.push_back({mean, slope});
  }
  std::tie(t.mean, t.slope) = deviation_terms(centre, a.nu_predicted, pr.nu.mean, use);
  t.mean_error = jackknife_error(terms, 0);
  t.slope_error = jackknife_error(terms, 1);
  t.from = centre[use.front()];
  t.to = centre[use.back()];
  t.strips = static_cast<int>(use.size());
  t.members = static_cast<int>(ok.size());
}

// The final density from the deposition density: a power law fitted to nu_d(y_i), carried to
// y_e by the fit of Delta y(y_e), against the measured nu(y_e).
void add_final_density(const PointResult& pr, const ObservableSettings& obs, PointAnalysis& a) {
  const double H = pr.point.params.height;
  std::vector<double> x;
  a.deposition_power_law =
      deposition_law(pr.nu_deposition, obs.lower_half_from_at(H), H, obs.strip_width, x);
  const std::vector<std::size_t> bins =
      profile_bins(pr.dy_by_ye, std::numeric_limits<double>::infinity());
  if (!a.deposition_power_law.valid() || !a.dy_by_ye.valid() || x.empty() || bins.empty()) return;
  const double y_lo = pr.dy_by_ye.position[bins.front()];
  const double y_hi = pr.dy_by_ye.position[bins.back()];
  a.nu_predicted = predicted_density(pr.nu.centre, a.deposition_power_law, a.dy_by_ye.coef, y_lo,
                                     y_hi, x.front(), x.back());
  double sum2 = 0.0;
  int n = 0;
  for (std::size_t k = 0; k < pr.nu.centre.size(); ++k) {
    a.nu_deviation[k] = a.nu_predicted[k] - pr.nu.mean[k];
    if (pr.nu.centre[k] >= obs.lower_half_from_at(H) && std::isfinite(a.nu_deviation[k])) {
      sum2 += a.nu_deviation[k] * a.nu_deviation[k];
      ++n;
    }
  }
  a.nu_rms_deviation = n > 0 ? std::sqrt(sum2 / n) : kNaN;
  add_deviation_terms(pr, obs, x.front(), x.back(), y_lo, y_hi, a);
}

// The fits of one point: histogram shapes, the avalanche profiles, the slice model (A) or the
// identities (C), and the final density from the deposition density.
PointAnalysis analyse_point(const PointResult& pr, const ObservableSettings& obs) {
  PointAnalysis a;
  const Protocol prot = pr.point.protocol;
  const double H = pr.point.params.height;
  const bool moves =
      prot == Protocol::C || (prot == Protocol::A && std::isfinite(pr.point.params.bond_number));
  a.abs_dy =
      histogram_shape(pr.abs_dy_edges, pr.abs_dy_counts, pr.abs_dy_member_counts, pr.m_failure);
  a.abs_dy_cut = histogram_shape(pr.abs_dy_edges, pr.abs_dy_counts_cut, pr.abs_dy_member_counts_cut,
                                 pr.m_failure);
  a.nu_predicted.assign(pr.nu.centre.size(), kNaN);
  a.nu_deviation.assign(pr.nu.centre.size(), kNaN);
  a.nu_rms_deviation = kNaN;
  if (!moves || pr.members - pr.failed < 2) return a;
  const int degree = prot == Protocol::A ? 2 : 1;
  a.dy_by_yi = profile_fit(pr.dy_by_yi, degree);
  a.dy_by_ye = profile_fit(pr.dy_by_ye, degree);
  if (prot == Protocol::A) {
    // The slice model without the top cut_top of the box: the paper's "crust", disks
    // deposited last that have hardly moved, which the slice model does not describe.
    a.slice_parabola = ensemble_fit(pr.dy_by_ye, H - obs.cut_top_at(H), 1, slice_basis(H));
  } else if (a.dy_by_ye.valid() && a.dy_by_yi.valid()) {
    add_identities(a);
  }
  add_final_density(pr, obs, a);
  return a;
}

// A C point's nu_i's standard error and the covariance of the means of nu_i and dnu/nu_i over its
// members, from their nu_i (members/nu_initial) and nu_f (members/nu_lower_half): a member whose
// initial deposit came out denser has a smaller increase. Files of programs before 2026-12-05
// lack the members' nu_i: {0, 0}, nu_i taken as exact (their fits were made so).
std::pair<double, double> initial_density_errors(const PointResult& pr) {
  if (pr.m_nu_initial.empty() || pr.m_nu_initial.size() != pr.m_nu_lower_half.size())
    return {0.0, 0.0};
  std::vector<double> ni, inc;
  for (std::size_t m = 0; m < pr.m_nu_initial.size(); ++m) {
    const double i = pr.m_nu_initial[m], f = pr.m_nu_lower_half[m];
    if (!std::isfinite(i) || !std::isfinite(f) || !(i > 0.0)) continue;
    ni.push_back(i);
    inc.push_back((f - i) / i);
  }
  const double n = static_cast<double>(ni.size());
  if (n < 2.0) return {kNaN, kNaN};
  const double mi = std::accumulate(ni.begin(), ni.end(), 0.0) / n;
  const double mc = std::accumulate(inc.begin(), inc.end(), 0.0) / n;
  double vi = 0.0, ci = 0.0;
  for (std::size_t m = 0; m < ni.size(); ++m) {
    vi += (ni[m] - mi) * (ni[m] - mi);
    ci += (ni[m] - mi) * (inc[m] - mc);
  }
  return {std::sqrt(vi / (n - 1.0) / n), ci / (n - 1.0) / n};
}

// The fits across scan points: the collapse's increase against ln H and nu_i (C), and the
// curvature and the slice model against H (A).
// A point whose disks moved by less than `moved` (observables.event_threshold) on average takes
// part in none: nothing there collapsed or slid, and its datum's error is the round-off of
// positions that did not change, which would pin the fit. A power law's datum must lie beyond
// three of its errors: sigma / y is ln y's error to first order only, and a datum within a few
// errors of zero (a curvature that is not resolved) would enter with an ln y its error does not
// describe.
ScanAnalysis analyse_across(const std::vector<PointResult>& points,
                            const std::vector<PointAnalysis>& fits, double moved) {
  ScanAnalysis out;
  const auto moving = [&](std::size_t k) { return points[k].mean_abs_dy.mean >= moved; };
  const auto resolved = [](double y, double sigma) { return y > 3.0 * sigma; };
  using Data = const std::vector<double>&;
  const auto line = [](Data x, Data y, Data s, Data, Data) { return polynomial_fit(x, y, s, 1); };
  const auto power_law = [](Data x, Data y, Data s, Data, Data) { return power_law_fit(x, y, s); };
  out.increase_vs_log_height =
      across_points(points, Protocol::C, Varying::Height, line, [&](std::size_t k) {
        const auto& inc = points[k].relative_increase;
        return keep_if(
            moving(k) && std::isfinite(inc.mean),
            {std::log(points[k].point.params.height), inc.mean, inc.sem, std::size_t(inc.n)});
      });
  // The initial density varies with the capture radius; fit against the measured nu_i, with its
  // error and its covariance with dnu/nu_i (measured on the same members).
  const auto power_law_xy = [](Data x, Data y, Data s, Data sx, Data c) {
    return power_law_fit(x, y, s, sx, c);
  };
  out.increase_vs_nu_initial =
      across_points(points, Protocol::C, Varying::CaptureRadius, power_law_xy, [&](std::size_t k) {
        const auto& inc = points[k].relative_increase;
        Datum d{points[k].nu_initial.mean, inc.mean, inc.sem, std::size_t(inc.n)};
        std::tie(d.sigma_x, d.cov) = initial_density_errors(points[k]);
        return keep_if(moving(k) && resolved(inc.mean, inc.sem), d);
      });
  out.quadratic_vs_height =
      across_points(points, Protocol::A, Varying::Height, power_law, [&](std::size_t k) {
        const Fit& f = fits[k].dy_by_ye;
        const bool curved = f.valid() && f.coef.size() >= 3 && resolved(coef(f, 2), err(f, 2));
        return keep_if(moving(k) && curved, {points[k].point.params.height, coef(f, 2), err(f, 2),
                                             jackknife_members(f)});
      });
  // The paper's 1/H follows from a profile H f(y/H): a slice model whose a does not change.
  const auto three_or_more = [](Data x, Data y, Data s, Data, Data) {
    return x.size() >= 3 ? power_law_fit(x, y, s) : Fit{};
  };
  out.slice_vs_height =
      across_points(points, Protocol::A, Varying::Height, three_or_more, [&](std::size_t k) {
        const Fit& f = fits[k].slice_parabola;
        const bool positive = f.valid() && !f.coef.empty() && resolved(coef(f, 0), err(f, 0));
        return keep_if(moving(k) && positive, {points[k].point.params.height, coef(f, 0), err(f, 0),
                                               jackknife_members(f)});
      });
  return out;
}

}  // namespace

Analysis analyse(const Scan& scan, const std::vector<PointResult>& points) {
  Analysis out;
  for (const auto& pr : points) out.points.push_back(analyse_point(pr, scan.observables));
  out.scan = analyse_across(points, out.points, scan.observables.event_threshold);
  return out;
}

}  // namespace loosepack
