// The theory of the paper evaluated on a scan's aggregates (docs/MODEL.md, "Theory evaluated
// on the results"): least-squares fits with ensemble errors, the final density
// predicted from the deposition density, the |Delta y| histogram shapes, and fits across scan
// points. Stored in the result file next to the data they fit (docs/OUTPUT.md).
#pragma once
#include <limits>
#include <string>
#include <vector>

#include "loosepack/observables.hpp"

namespace loosepack {

// A least-squares fit. coef[k] and error[k]: the k-th parameter and its standard error. With
// per-point standard errors (weighted fit) the errors come from them and are scaled up by
// sqrt(chi2 / dof) where that exceeds one (the data scatter more than their errors say);
// without them, from the residual scatter. The avalanche-profile fits of PointAnalysis are
// unweighted, through the bins every member reaches, with errors from a jackknife over members
// and chi2 of the residuals against their jackknife errors (src/analysis.cpp, ensemble_fit).
struct Fit {
  std::vector<double> coef, error;
  // Avalanche-profile and histogram fits with errors from the members: the coefficients refitted
  // with each member left out in turn (the members that did not fail, in member order), for the
  // jackknife of quantities derived from several fits of the same members. Not stored in the
  // file.
  std::vector<std::vector<double>> replicas;
  double chi2 = 0.0;  // weighted residual sum of squares (Pearson chi2 for histogram fits)
  // Avalanche-profile and histogram fits with errors from the members: the term the model lacks,
  // the highest coefficient of the fit one degree higher over its jackknife error (Student's t
  // with members - 1 degrees of freedom whatever the bins' correlation, for members whose
  // coefficients scatter about normally); NaN where there is none.
  double next_term_t = std::numeric_limits<double>::quiet_NaN();
  // Histogram fits with errors from the members: the term after that, the highest coefficient of
  // the fit two degrees higher over its jackknife error; NaN where there is none.
  double second_term_t = std::numeric_limits<double>::quiet_NaN();
  int points = 0;     // data points used
  int dof = 0;        // points - parameters
  // Fits across scan points: the indices of the scan points the fit went through, in scan
  // order (empty for the fits of one point).
  std::vector<int> scan_points;
  bool valid() const { return dof >= 0 && points > 0 && !coef.empty(); }
  double reduced_chi2() const;
};

// y = sum_k coef[k] x^k up to `degree`. Points with a non-finite x or y, or (when sigma is
// given) a non-finite or non-positive sigma, are skipped. Returns an invalid fit (no
// coefficients) when fewer points than parameters remain.
Fit polynomial_fit(const std::vector<double>& x, const std::vector<double>& y,
                   const std::vector<double>& sigma, int degree);
double polynomial(const Fit& f, double x);

// Power law y = A x^p, fitted as ln y = ln A + p ln x (sigma_ln = sigma / y); coef = {ln A, p}.
// Points with x or y not positive are left out; sigma may be empty (unweighted).
Fit power_law_fit(const std::vector<double>& x, const std::vector<double>& y,
                  const std::vector<double>& sigma);
// The same with errors in x too: sigma_x, x's standard errors, and cov, the covariance of each
// x's and y's errors (a datum's x and y measured on the same members). Fitted by effective
// variance (Orear 1982): ln y - p ln x has the variance s_y^2 + p^2 s_x^2 - 2 p c (in logs:
// s = sigma / value, c = cov / (x y)), with which the line is refitted as p changes until p
// settles; coefficients' errors and chi2 are the last weighted fit's. Where x's fluctuation moves
// a datum along the law (c of the law's sign), the effective error is smaller than y's own, and
// chi2 judges the law by the rest. A datum whose effective variance is not positive is skipped;
// an invalid fit where p does not settle, or where sigma, sigma_x or cov is empty.
Fit power_law_fit(const std::vector<double>& x, const std::vector<double>& y,
                  const std::vector<double>& sigma, const std::vector<double>& sigma_x,
                  const std::vector<double>& cov);

// |Delta y| histogram shapes: ln n = alpha + beta x (exponential, decay length -1/beta) and
// ln n = alpha + beta x + gamma x^2 (Gaussian: mean -beta / (2 gamma), width sqrt(-1 / (2 gamma))),
// fitted to the counts as Poisson's by maximum likelihood over the band of bins between the
// counts' 0.5 % and 99.5 % quantiles, empty bins within included (a least-squares fit of ln n over
// the bins with disks bends up at a tail's last bins, those that fluctuated up). With the members'
// own counts (`member_counts`, one row per member, a failed member's row 0) and at least 4 members
// that did not fail (`member_failure` 0 where it has a value per row, else the rows with disks)
// each fit's errors come from a jackknife over the members, whose scatter holds the avalanches'
// (the disks one avalanche moves together land in the same bins, so the counts scatter far more
// than Poisson's sqrt(n)), and its chi2 is that of the counts' residuals against the residuals'
// own jackknife errors, as the avalanche-profile fits'. That chi2 counts neighbouring bins, which
// move together, as independent and rejects a right shape more often than 1 %; so each shape is
// judged by its next two terms instead (`next_term_t`, `second_term_t`: the highest coefficient
// of the fits one and two degrees higher over its jackknife error, Student's t with members - 1
// degrees of freedom), each within its two-sided 99.5 % bound. Akaike's criterion chooses the
// shape, the difference of the two chi2 taken from the quadratic term's t (the exponential's
// `next_term_t`) as its chi2 term (`quadratic_chi2`, chi2_term_of_t): the Gaussian where that
// exceeds 2 (it must have a maximum, gamma < 0), else the exponential; the chosen shape must hold
// by its terms, else "neither" (also where a member's absence leaves the Gaussian without a fit).
// Without the members' counts chi2 is Pearson's (counts against the model), Akaike's criterion
// takes it as it is, and the chosen shape must fit, chi2 at most its 99 % quantile. "none": too
// few bins (six, with the members' counts, for the quartic and a degree of freedom).
struct HistogramShape {
  Fit exponential, gaussian;
  double decay_length = 0.0, gaussian_mean = 0.0, gaussian_width = 0.0;
  bool member_errors = false;  // chi2 and errors from the members' scatter (else Pearson's chi2)
  static constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  double quadratic_chi2 = kNone;  // with member_errors
  // Each shape judged on its own, as the verdict judges the one Akaike's criterion chooses: it
  // holds by its next two terms (with member_errors) or fits by Pearson's chi2; the Gaussian
  // also needs its maximum.
  bool exponential_acceptable = false, gaussian_acceptable = false;
  std::string preferred;  // "gaussian", "exponential", "neither", or "none" (too few bins)
};
HistogramShape histogram_shape(const std::vector<double>& edges, const std::vector<double>& counts,
                               const std::vector<std::vector<double>>& member_counts = {},
                               const std::vector<double>& member_failure = {});

// The 99 % quantile of chi2 with `dof` degrees of freedom (Wilson and Hilferty; within 1 % of
// the exact quantile from 3 degrees of freedom on).
double chi2_quantile99(double dof);

// The square of the standard normal deviate with the tail probability of Student's t with nu
// degrees of freedom at t (Wallace 1959: z = (8 nu + 1)/(8 nu + 3) sqrt(nu ln(1 + t^2/nu)),
// within 2 % of the exact deviate up to |t| = 10 from nu = 3 on). A deviation measured against an
// error estimated from nu + 1 members is such a t; its term in a chi2 is this, so that the sum
// has chi2's distribution, tail included, and chi2_quantile99 bounds it at any number of members.
double chi2_term_of_t(double t, double nu);

struct PointAnalysis {
  // Avalanche profiles: parabolas (protocol A) or lines (C): Delta y = c0 + c1 y (+ c2 y^2).
  Fit dy_by_yi, dy_by_ye;
  Fit slice_parabola;  // A: -a y_e (1 - y_e/H)
  // C: the lines' coefficient identity (paper: Delta y(y_e) = a - b y_e, Delta y(y_i) = a' - b'
  // y_i, then b' = b/(1+b), a' = a/(1+b)): the fitted b', a' and the ones predicted from b, a;
  // all of these NaN where the lines have no fit (fewer than two members).
  static constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  double b_prime = kNone, b_prime_error = kNone, b_prime_predicted = kNone,
         b_prime_predicted_error = kNone;
  double a_prime = kNone, a_prime_error = kNone, a_prime_predicted = kNone,
         a_prime_predicted_error = kNone;
  // The differences b' - b/(1+b) and a' - a/(1+b), with the jackknife error of each difference
  // over the members (the two lines come from the same members, so the combined errors above
  // overstate it); NaN errors without per-member rows.
  double b_prime_difference = kNone, b_prime_difference_error = kNone;
  double a_prime_difference = kNone, a_prime_difference_error = kNone;
  // C: -d(Delta y)/dy_e (= b) beside the measured relative density increase.
  double slope_increase = kNone, slope_increase_error = kNone;
  // Final density from the deposition density, rho_f(y_e) = rho_d(y_i(y_e)) (1 - dDelta y/dy_e),
  // with the fitted avalanche profile against y_e and a power law fitted to nu_d(y_i):
  // predicted nu per strip of the nu profile (NaN outside the fitted range) and the deviation
  // predicted - measured; rms over the strips above lower_half_from that have a prediction.
  Fit deposition_power_law;
  std::vector<double> nu_predicted, nu_deviation;
  double nu_rms_deviation = 0.0;
  // The deviation's two lowest terms over the strips from lower_half_from to cut_top below the
  // lowest member's top (`from`, `to` their centres): its mean and its slope in y, each with its
  // jackknife error over the members, the prediction refitted without each member as the
  // measured density is averaged without it (both come from the same members and move together,
  // so the measured density's error alone would overstate the deviation's). NaN without per-member
  // rows or with fewer than 4 members.
  struct DeviationTerms {
    double mean = kNone, mean_error = kNone, slope = kNone, slope_error = kNone, from = kNone,
           to = kNone;
    int strips = 0, members = 0;
  } nu_deviation_terms;
  HistogramShape abs_dy, abs_dy_cut;
};

// Fits across the scan points (each needs at least three points that differ in the variable).
struct ScanAnalysis {
  Fit increase_vs_log_height;  // C: dnu/nu_i = c0 + c1 ln H (points differing in H)
  Fit increase_vs_nu_initial;  // C: dnu/nu_i = A nu_i^p (points differing in nu_i)
  Fit quadratic_vs_height;     // A: c of the Delta y(y_e) parabola = A H^p (paper: p = -1), over
                               // the points where c lies beyond three errors above 0
  Fit slice_vs_height;         // A: the slice model's a = A H^p (paper: p = 0, so c = a/H ~ 1/H)
};

struct Analysis {
  std::vector<PointAnalysis> points;  // one per scan point, in order
  ScanAnalysis scan;
};

Analysis analyse(const Scan& scan, const std::vector<PointResult>& points);

}  // namespace loosepack
