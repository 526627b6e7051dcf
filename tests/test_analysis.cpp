// The fits and theory checks of the analysis, on data whose answers are known in closed form.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numeric>
#include <random>
#include <string>

#include "loosepack/analysis.hpp"
#include "loosepack/output.hpp"
#include "loosepack/protocols.hpp"
#include "tests/run_helpers.hpp"

using namespace loosepack;

namespace {

// A synthetic ensemble with known answers: for every member of the scan, count(m) disks of radius
// 1 at uniform random x across the box (overlaps do not matter to the analysis), each deposited
// at y_i and ending at y_e, (y_i, y_e) = disk(m, rng).
template <class Count, class Disk>
std::vector<MemberResult> synthetic_ensemble(const Scan& scan, std::uint64_t seed, Count count,
                                             Disk disk) {
  std::vector<MemberResult> results;
  std::mt19937_64 rng(seed);
  for (const auto& m : members_of(scan)) {
    MemberResult r;
    r.member = m;
    std::uniform_real_distribution<double> ux(0.0, m.params.width);
    const int n = count(m);
    for (int k = 0; k < n; ++k) {
      const auto [yi, ye] = disk(m, rng);
      r.x.push_back(ux(rng));
      r.y_i.push_back(yi);
      r.y_e.push_back(ye);
      r.radius.push_back(1.0);
    }
    results.push_back(std::move(r));
  }
  return results;
}

// The slice model's final height: y_i = y_e - Delta y(y_e) = (1 + alpha) y_e - (alpha/H) y_e^2,
// solved for y_e in [0, H].
double slice_model_final_height(double yi, double alpha, double H) {
  const double c = alpha / H;
  return ((1.0 + alpha) - std::sqrt((1.0 + alpha) * (1.0 + alpha) - 4.0 * c * yi)) / (2.0 * c);
}

// Protocol C, 8 members of 200 R x 120 R at Bo = 1e3, the density band from 8 R.
Scan collapse_scan() {
  return parse_scan(R"(
[scan]
protocol = "C"
seeds = 8
[system]
width = 200.0
height = 120.0
bond_number = 1000
[observables]
lower_half_from = 8.0
)",
                    "synthetic.toml");
}

// Protocol A in a 40 R x 80 R box with 4 R profile bins: `seeds` members at Bond number `bo`.
Scan profile_scan(int seeds, int bo) {
  return parse_scan(
      "[scan]\nprotocol = \"A\"\nseeds = " + std::to_string(seeds) +
          "\n[system]\nwidth = 40.0\nheight = 80.0\nbond_number = " + std::to_string(bo) +
          "\n[observables]\nlower_half_from = 4.0\nbin_width = 4.0\n",
      "synthetic.toml");
}

// The smallest k with P(X <= k) >= q for X ~ Binomial(n, p): how many of n tests at level p may
// reject a true model before the level itself is in doubt (q = 0.999).
int binomial_quantile(int n, double p, double q) {
  double term = std::pow(1.0 - p, n), cdf = term;  // P(X = 0)
  int k = 0;
  while (cdf < q && k < n) {
    term *= (n - k) / (k + 1.0) * p / (1.0 - p);
    cdf += term;
    ++k;
  }
  return k;
}

// A lumpy |Delta y| histogram ensemble, as avalanches make one: `members` rows of 150 lumps of 1 to
// 40 disks each (geometric, mean 8; an avalanche's disks), in 60 bins of 0.5 R. Each lump draws
// its value `lump()`, then each of its disks lands at `disk(value)` (the lump's value, or values
// near it); disks beyond the last bin are left out.
constexpr int kLumpyBins = 60;
constexpr double kLumpyBin = 0.5;
std::vector<double> lumpy_edges() {
  std::vector<double> edges;
  for (int k = 0; k <= kLumpyBins; ++k) edges.push_back(k * kLumpyBin);
  return edges;
}
struct LumpyHistograms {
  std::vector<double> total;
  std::vector<std::vector<double>> rows;
};
template <class Lump, class DiskOf>
LumpyHistograms lumpy_histograms(std::mt19937_64& rng, int members, Lump lump, DiskOf disk) {
  constexpr int kLumps = 150, kBins = kLumpyBins;
  constexpr double kBin = kLumpyBin;
  LumpyHistograms h;
  h.total.assign(kBins, 0.0);
  h.rows.assign(static_cast<std::size_t>(members), std::vector<double>(kBins, 0.0));
  std::geometric_distribution<int> disks(1.0 / 8.0);
  for (auto& row : h.rows)
    for (int l = 0; l < kLumps; ++l) {
      const double value = lump();
      for (int d = std::min(40, 1 + disks(rng)); d > 0; --d) {
        const double b = std::floor(disk(value) / kBin);
        if (!(b >= 0.0 && b < kBins)) continue;
        row[static_cast<std::size_t>(b)] += 1.0;
        h.total[static_cast<std::size_t>(b)] += 1.0;
      }
    }
  return h;
}

}  // namespace

// Noise-free data: the fit returns the generating coefficients.
TEST(Analysis, PolynomialFitRecoversAParabola) {
  std::vector<double> x, y;
  for (int k = 0; k < 20; ++k) {
    x.push_back(2.0 + 4.0 * k);
    y.push_back(-1.8 - 0.31 * x.back() + 0.00035 * x.back() * x.back());
  }
  const Fit f = polynomial_fit(x, y, {}, 2);
  ASSERT_TRUE(f.valid());
  EXPECT_EQ(f.dof, 17);
  EXPECT_NEAR(f.coef[0], -1.8, 1e-9);
  EXPECT_NEAR(f.coef[1], -0.31, 1e-11);
  EXPECT_NEAR(f.coef[2], 0.00035, 1e-13);
  EXPECT_NEAR(polynomial(f, 100.0), -1.8 - 31.0 + 3.5, 1e-9);
}

// One bin whose error is a million times smaller than the others' (disks that did not move at
// all): the weighted fit is still well defined, passes through that point, and recovers
// noise-free coefficients (the normal equations were too ill-conditioned to solve here).
TEST(Analysis, WeightedFitWithOneTinyErrorBin) {
  std::vector<double> x, y, s;
  for (int k = 0; k < 24; ++k) {
    x.push_back(2.0 + 4.0 * k);
    y.push_back(0.3 - 0.25 * x.back() + 0.0025 * x.back() * x.back());
    s.push_back(k == 23 ? 1e-6 : 1.0);
  }
  const Fit f = polynomial_fit(x, y, s, 2);
  ASSERT_TRUE(f.valid());
  EXPECT_NEAR(f.coef[0], 0.3, 1e-8);
  EXPECT_NEAR(f.coef[1], -0.25, 1e-9);
  EXPECT_NEAR(f.coef[2], 0.0025, 1e-11);
  EXPECT_TRUE(std::isfinite(f.error[2]) && f.error[2] > 0.0);
}

// Weighted straight line with equal sigma: the slope's standard error is
// sigma / sqrt(sum (x - mean x)^2) when chi2/dof <= 1 (no rescaling).
TEST(Analysis, WeightedLineErrorsFollowTheTextbookFormula) {
  const double sigma = 0.1;
  std::vector<double> x, y, s;
  // Residuals +-0.05 alternate: chi2/dof < 1, so the errors are the sigma-based ones.
  for (int k = 0; k < 10; ++k) {
    x.push_back(k);
    y.push_back(1.0 + 2.0 * k + (k % 2 ? 0.05 : -0.05));
    s.push_back(sigma);
  }
  const Fit f = polynomial_fit(x, y, s, 1);
  ASSERT_TRUE(f.valid());
  double sxx = 0.0;
  for (double v : x) sxx += (v - 4.5) * (v - 4.5);
  EXPECT_LT(f.reduced_chi2(), 1.0);
  EXPECT_NEAR(f.error[1], sigma / std::sqrt(sxx), 1e-12);
  EXPECT_NEAR(f.error[0], sigma * std::sqrt(1.0 / 10.0 + 4.5 * 4.5 / sxx), 1e-12);
  // Too few points for a parabola through 2 points: invalid.
  EXPECT_FALSE(polynomial_fit({1.0, 2.0}, {1.0, 2.0}, {}, 2).valid());
}

// The slice model's fit is the profile's (PointAnalysis::slice_parabola, checked on exact
// displacements in AvalancheParabolaScalesLikeOneOverHeightAndPredictsTheFinalDensity).
TEST(Analysis, PowerLawRecoversItsExponent) {
  std::vector<double> x, nu;
  for (double v = 10.0; v < 400.0; v += 8.0) {
    x.push_back(v);
    nu.push_back(0.2 * std::pow(v, 0.15));
  }
  const Fit p = power_law_fit(x, nu, {});
  ASSERT_TRUE(p.valid());
  EXPECT_NEAR(std::exp(p.coef[0]), 0.2, 1e-10);
  EXPECT_NEAR(p.coef[1], 0.15, 1e-12);
}

// Histograms drawn from an exponential and from a Gaussian: each is recognised, and the fitted
// decay length, mean and width are those of the distribution within sampling error.
TEST(Analysis, HistogramShapeTellsGaussianFromExponential) {
  std::mt19937_64 rng(12345);
  const int n = 20000;
  const double bin = 0.5;
  std::vector<double> edges;
  for (int k = 0; k <= 80; ++k) edges.push_back(k * bin);
  auto histogram = [&](auto draw) {
    std::vector<double> counts(80, 0.0);
    for (int k = 0; k < n; ++k) {
      const double v = std::fabs(draw());
      const int b = static_cast<int>(v / bin);
      if (b < 80) counts[static_cast<std::size_t>(b)] += 1.0;
    }
    return counts;
  };
  std::exponential_distribution<double> expo(1.0 / 1.5);  // decay length 1.5 R
  std::normal_distribution<double> gauss(12.0, 3.0);
  const auto he = histogram([&] { return expo(rng); });
  const auto hg = histogram([&] { return gauss(rng); });
  const HistogramShape se = histogram_shape(edges, he);
  const HistogramShape sg = histogram_shape(edges, hg);
  // Within five standard errors of the maximum-likelihood estimates from n draws: lambda /
  // sqrt(n) for the decay length, sigma / sqrt(n) for the mean, sigma / sqrt(2 n) for the width
  // (0.011, 0.021 and 0.015 here); a fit to the binned counts is at most a little less precise.
  const double draws = n;
  EXPECT_EQ(se.preferred, "exponential");
  EXPECT_NEAR(se.decay_length, 1.5, 5.0 * 1.5 / std::sqrt(draws));
  EXPECT_EQ(sg.preferred, "gaussian");
  EXPECT_NEAR(sg.gaussian_mean, 12.0, 5.0 * 3.0 / std::sqrt(draws));
  EXPECT_NEAR(sg.gaussian_width, 3.0, 5.0 * 3.0 / std::sqrt(2.0 * draws));
  // The exponential fit of Gaussian data is far worse than the Gaussian fit.
  EXPECT_GT(sg.exponential.reduced_chi2(), 10.0 * sg.gaussian.reduced_chi2());
}

// Avalanches move disks in lumps: every disk of a lump gets the same |Delta y|, so the counts
// scatter far beyond Poisson's sqrt(n). 16 members of 150 lumps (1 to 40 disks, geometric with
// mean 8) each: with the members' counts, a shape that is right holds (its next two terms within
// their bound) and is preferred; judged by Pearson's chi2 instead, the same right shape is
// rejected ("neither"); and a two-humped distribution, which neither shape describes, is
// "neither" with the members' counts too: neither shape is acceptable.
TEST(Analysis, HistogramShapeNeedsAFitWithinTheMembersScatter) {
  std::mt19937_64 rng(2026);
  const int members = 16;
  const std::vector<double> edges = lumpy_edges();
  auto ensemble = [&](auto draw) {  // every disk of a lump in its bin
    auto h = lumpy_histograms(
        rng, members, [&] { return std::fabs(draw()); }, [](double v) { return v; });
    return std::pair(h.total, h.rows);
  };
  std::normal_distribution<double> gauss(12.0, 3.0), low(7.0, 1.0), high(17.0, 1.0);
  std::exponential_distribution<double> expo(1.0 / 3.0);
  std::bernoulli_distribution coin(0.5);
  const auto [g, g_rows] = ensemble([&] { return gauss(rng); });
  const auto [e, e_rows] = ensemble([&] { return expo(rng); });
  const auto [b, b_rows] = ensemble([&] { return coin(rng) ? low(rng) : high(rng); });

  const HistogramShape sg = histogram_shape(edges, g, g_rows);
  EXPECT_TRUE(sg.member_errors);
  EXPECT_EQ(sg.preferred, "gaussian");
  EXPECT_TRUE(sg.gaussian_acceptable);
  // The lumps weigh the draws: of the 2 400 lumps, (sum w)^2 / sum w^2 = 2 400 E[w]^2 / E[w^2]
  // (about 64 / 120) count, n_eff ~ 1 300, so the bounds below are 6 (mean: 3 / sqrt(n_eff)),
  // 7 (width: 3 / sqrt(2 n_eff)) and 5 (decay length: 3 / sqrt(n_eff)) standard errors.
  EXPECT_NEAR(sg.gaussian_mean, 12.0, 0.5);
  EXPECT_NEAR(sg.gaussian_width, 3.0, 0.4);
  const HistogramShape se = histogram_shape(edges, e, e_rows);
  EXPECT_EQ(se.preferred, "exponential");
  EXPECT_NEAR(se.decay_length, 3.0, 0.4);

  // Pearson's chi2 takes the lumps' scatter for misfit.
  const HistogramShape pearson = histogram_shape(edges, g);
  EXPECT_FALSE(pearson.member_errors);
  EXPECT_GT(pearson.gaussian.chi2, chi2_quantile99(pearson.gaussian.dof));
  EXPECT_EQ(pearson.preferred, "neither");

  const HistogramShape sb = histogram_shape(edges, b, b_rows);
  EXPECT_TRUE(sb.member_errors);
  EXPECT_FALSE(sb.gaussian_acceptable);
  EXPECT_FALSE(sb.exponential_acceptable);  // by its next two terms alone
  EXPECT_EQ(sb.preferred, "neither");
}

// A histogram whose tail bins hold one member's disks alone: without that member the Gaussian has
// two bins with counts for three parameters (no maximum of the likelihood), so its jackknife, and
// with it the quadratic term's t, does not exist. The shapes cannot be told apart: "neither", not
// the exponential by default. Nor are its errors the members' (Poisson's would pass for them).
TEST(Analysis, HistogramShapeWithoutTheGaussiansJackknifeIsNeither) {
  const std::vector<double> edges = {0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0};
  const std::vector<double> lone = {10.0, 8.0, 12.0, 6.0, 4.0, 3.0}, rest = {10.0, 8.0, 0, 0, 0, 0};
  const std::vector<std::vector<double>> rows = {lone, rest, rest, rest};
  const std::vector<double> total = {40.0, 32.0, 12.0, 6.0, 4.0, 3.0};
  const HistogramShape h = histogram_shape(edges, total, rows);
  ASSERT_TRUE(h.gaussian.valid());  // the whole ensemble's four bins determine it
  EXPECT_TRUE(h.member_errors);
  EXPECT_TRUE(std::isnan(h.gaussian.chi2));
  for (double e : h.gaussian.error) EXPECT_TRUE(std::isnan(e));
  EXPECT_TRUE(std::isnan(h.exponential.next_term_t));
  EXPECT_TRUE(std::isnan(h.quadratic_chi2));
  EXPECT_EQ(h.preferred, "neither");
}
// The choice between the shapes and the exponential's own test are calibrated where the chi2 are
// not: in ensembles of 16 members whose |Delta y| are exponential disk by disk, the quadratic
// term's chi2 exceeds Akaike's 2 (the Gaussian where c2 < 0, "neither" where it is positive) as
// often as a chi2 of one degree of freedom does, 15.7 %, and the exponential's next two terms
// leave their bound in 1 %: each count of 1 000 ensembles within the binomial's 0.1 % and 99.9 %
// quantiles of its rate. Two kinds of members: lumps of nearby values (a lump's disks at
// probabilities within about 0.02 of one another, so neighbouring bins move together, as an
// avalanche's disks do), where the plain chi2 are not calibrated: the difference of the two
// shapes' chi2 exceeds 2, and the exponential's chi2 its 99 % quantile, more often than those
// rates allow (beyond their 99.9 % quantiles); and disks that move one by one (counts near
// Poisson's), where c2 is as often negative as positive (the Gaussian and "neither" each at half
// the quadratic's rate: a fit of ln n over the bins with 5 disks or more, whose tail ends in bins
// that fluctuated up, made it positive more often).
TEST(Analysis, HistogramShapeChoosesTheGaussianForAnExponentialAsAkaikeSays) {
  std::mt19937_64 rng(11);
  const int members = 16, ensembles = 1000;
  const double scale = 3.0;
  const std::vector<double> edges = lumpy_edges();
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> jitter(0.0, 0.02);
  struct Counts {
    int quadratic = 0, gaussian = 0, neither = 0, by_chi2 = 0, chi2_rejects = 0, terms_reject = 0;
  };
  auto count = [&](auto disk) {
    Counts c;
    for (int e = 0; e < ensembles; ++e) {
      const auto [total, rows] = lumpy_histograms(
          rng, members, [&] { return uniform(rng); }, disk);
      const HistogramShape h = histogram_shape(edges, total, rows);
      EXPECT_TRUE(h.member_errors);
      c.quadratic += h.quadratic_chi2 > 2.0;
      c.gaussian += h.preferred == "gaussian";
      c.neither += h.preferred == "neither";
      c.by_chi2 += h.exponential.chi2 - h.gaussian.chi2 > 2.0;
      c.chi2_rejects += !(h.exponential.chi2 <= chi2_quantile99(h.exponential.dof));
      c.terms_reject += !h.exponential_acceptable;
    }
    std::printf(
        "quadratic %d (gaussian %d, neither %d), by chi2 %d; exponential rejected by chi2 %d, "
        "by its terms %d, of %d\n",
        c.quadratic, c.gaussian, c.neither, c.by_chi2, c.chi2_rejects, c.terms_reject, ensembles);
    return c;
  };
  const Counts lumps = count([&](double u0) {
    double u = u0 + jitter(rng);
    u -= std::floor(u);  // uniform for every disk: each disk's |Delta y| is exponential
    return -scale * std::log1p(-u);
  });
  const double akaike = std::erfc(1.0);  // P(chi2 of one degree of freedom > 2) = 0.157
  const auto within = [&](int count, double rate) {
    EXPECT_GE(count, binomial_quantile(ensembles, rate, 0.001)) << "rate " << rate;
    EXPECT_LE(count, binomial_quantile(ensembles, rate, 0.999)) << "rate " << rate;
  };
  within(lumps.quadratic, akaike);
  EXPECT_GT(lumps.by_chi2, binomial_quantile(ensembles, akaike, 0.999));
  EXPECT_GT(lumps.chi2_rejects, binomial_quantile(ensembles, 0.01, 0.999));
  EXPECT_LE(lumps.terms_reject, binomial_quantile(ensembles, 0.01, 0.999));
  const Counts one_by_one = count([&](double) { return -scale * std::log1p(-uniform(rng)); });
  within(one_by_one.quadratic, akaike);
  within(one_by_one.gaussian, akaike / 2.0);
  within(one_by_one.neither, akaike / 2.0);
  EXPECT_LE(one_by_one.terms_reject, binomial_quantile(ensembles, 0.01, 0.999));
}

// The Gaussian's next term is Student's t where the shape is Gaussian, and its next two terms
// judge it: 16 members of 150 lumps (1 to 40 disks) whose centres are drawn from a distribution and
// whose disks lie 0.3 R about them (a lump of one avalanche moves its disks by nearby amounts).
// From a Gaussian (12 R, 3 R; with the disks' spread a Gaussian of width sqrt(9.09) R) the cubic's
// t exceeds the two-sided 99 % bound of t with 15 degrees of freedom (2.947) in about 1 % of 200
// ensembles, and the verdict is the Gaussian but for about 1 % (its cubic or quartic beyond their
// 99.5 % bounds); from a Gumbel distribution (mode 10 R, scale 3 R, skewness 1.14) the cubic's t is
// beyond in nearly all of 20, and the verdict "neither".
TEST(Analysis, HistogramGaussiansNextTermIsStudentsTAndShowsASkew) {
  std::mt19937_64 rng(17);
  const int members = 16;
  const double bound = 2.947;
  const std::vector<double> edges = lumpy_edges();
  std::normal_distribution<double> gauss(12.0, 3.0), spread(0.0, 0.3);
  std::extreme_value_distribution<double> gumbel(10.0, 3.0);
  struct Counts {
    int cubic_beyond = 0, not_gaussian = 0;
  };
  auto count = [&](auto& centre, int ensembles) {
    Counts c;
    for (int e = 0; e < ensembles; ++e) {
      const auto [total, rows] = lumpy_histograms(
          rng, members, [&] { return centre(rng); },
          [&](double v) { return std::fabs(v + spread(rng)); });
      const HistogramShape h = histogram_shape(edges, total, rows);
      EXPECT_TRUE(std::isfinite(h.gaussian.next_term_t) && std::isfinite(h.gaussian.second_term_t));
      c.cubic_beyond += std::fabs(h.gaussian.next_term_t) > bound;
      c.not_gaussian += h.preferred != "gaussian";
    }
    return c;
  };
  const Counts gaussian = count(gauss, 200), skewed = count(gumbel, 20);
  std::printf(
      "cubic's t beyond %.3f: Gaussian %d of 200, Gumbel %d of 20; verdict not the "
      "Gaussian: %d of 200, %d of 20\n",
      bound, gaussian.cubic_beyond, skewed.cubic_beyond, gaussian.not_gaussian,
      skewed.not_gaussian);
  EXPECT_LE(gaussian.cubic_beyond, binomial_quantile(200, 0.01, 0.999));
  EXPECT_LE(gaussian.not_gaussian, binomial_quantile(200, 0.01, 0.999));
  EXPECT_GE(skewed.cubic_beyond, 18);
  EXPECT_GE(skewed.not_gaussian, 18);
}

// A member that finished with no disk in the histogram's band (its row all zero) is a member of
// the ensemble, and the jackknife has a replica for it; a failed member's row (also zero) has
// none. The failure flags tell them apart where the rows cannot.
TEST(Analysis, HistogramJackknifeCountsAFinishedMemberWithoutDisksInTheBand) {
  std::mt19937_64 rng(7);
  const int n_bins = 30;
  std::vector<double> edges;
  for (int k = 0; k <= n_bins; ++k) edges.push_back(0.5 * k);
  std::exponential_distribution<double> expo(1.0 / 3.0);
  std::vector<std::vector<double>> rows(6, std::vector<double>(n_bins, 0.0));
  std::vector<double> total(n_bins, 0.0);
  for (std::size_t m = 0; m < 5; ++m)  // row 5 stays empty
    for (int d = 0; d < 400; ++d) {
      const int b = std::min(n_bins - 1, static_cast<int>(expo(rng) / 0.5));
      rows[m][static_cast<std::size_t>(b)] += 1.0;
      total[static_cast<std::size_t>(b)] += 1.0;
    }
  const HistogramShape finished = histogram_shape(edges, total, rows, {0, 0, 0, 0, 0, 0});
  const HistogramShape failed = histogram_shape(edges, total, rows, {0, 0, 0, 0, 0, 2});
  const HistogramShape unflagged = histogram_shape(edges, total, rows);
  EXPECT_EQ(finished.exponential.replicas.size(), 6u);
  EXPECT_EQ(failed.exponential.replicas.size(), 5u);
  EXPECT_EQ(unflagged.exponential.replicas.size(), 5u);
  // Without the empty row the other members' counts are scaled to the six members' total,
  // which moves ln n by ln(6/5) and leaves the decay as the whole ensemble's.
  const auto& empty_out = finished.exponential.replicas.back();
  EXPECT_NEAR(empty_out[0], finished.exponential.coef[0] + std::log(6.0 / 5.0), 1e-9);
  EXPECT_NEAR(empty_out[1], finished.exponential.coef[1], 1e-9);
}

// The final density predicted from the initial one, judged by the deviation's mean and slope
// with their jackknife over the members (the prediction refitted without each member): members
// that collapse along exact lines (y_e = y_i + a' - b'_m y_i) from uniform deposits of random
// disks, all with b' = 0.39 or each with its own (0.34-0.44), so the prediction is right but for
// the disks' noise and the members' spread, in which the prediction and the measured density
// move together. Over 100 ensembles of 8 members each term's t spreads by 0.81-1.00 (Student's
// t with 7 degrees of freedom: 1.18; the jackknife errs on the large side, not the small, as the
// measured density's error alone would) and stays within its two-sided 99.5 % bound (4.05).
TEST(Analysis, PredictedFinalDensityDeviationHasJackknifeErrors) {
  const auto scan = collapse_scan();
  const double a_prime = 1.9;
  std::uniform_real_distribution<double> uy(1.0, 119.0);
  for (const double spread : {0.0, 0.05}) {
    double sum2_mean = 0.0, sum2_slope = 0.0;
    int beyond = 0, ensembles = 0;
    for (int e = 0; e < 100; ++e) {
      const auto results = synthetic_ensemble(
          scan, 500 + e,
          [](const Member&) { return static_cast<int>(0.35 * 200.0 * 118.0 / M_PI); },
          [&](const Member& m, std::mt19937_64& rng) {
            const double yi = uy(rng);
            const double b_prime = 0.39 + spread * std::sin(1.0 + 7.3 * m.seed_index + 0.37 * e);
            return std::pair(yi, yi + a_prime - b_prime * yi);
          });
      const auto t = analyse(scan, aggregate(scan, results)).points.at(0).nu_deviation_terms;
      ASSERT_EQ(t.members, 8);
      ASSERT_GE(t.strips, 3);
      const double tm = t.mean / t.mean_error, ts = t.slope / t.slope_error;
      sum2_mean += tm * tm;
      sum2_slope += ts * ts;
      beyond += (std::fabs(tm) > 4.05) + (std::fabs(ts) > 4.05);
      ++ensembles;
    }
    const double sd_mean = std::sqrt(sum2_mean / ensembles);
    const double sd_slope = std::sqrt(sum2_slope / ensembles);
    std::printf("b' spread %.2f: t spread mean %.2f, slope %.2f; beyond the bound %d of %d\n",
                spread, sd_mean, sd_slope, beyond, 2 * ensembles);
    for (const double sd : {sd_mean, sd_slope}) {
      EXPECT_GT(sd, 0.6) << spread;
      EXPECT_LT(sd, 1.6) << spread;
    }
    EXPECT_LE(beyond, binomial_quantile(2 * ensembles, 0.005, 0.999)) << spread;
  }
}

// The 99 % quantile of chi2: Wilson and Hilferty's approximation against tabulated values.
TEST(Analysis, Chi2QuantileMatchesTables) {
  EXPECT_NEAR(chi2_quantile99(5), 15.086, 0.1);
  EXPECT_NEAR(chi2_quantile99(10), 23.209, 0.1);
  EXPECT_NEAR(chi2_quantile99(30), 50.892, 0.1);
}

// A synthetic protocol-C ensemble: disks of a uniform deposit (volume fraction nu_i) collapse
// along the exact line y_e = y_i + a' - b' y_i. Then Delta y(y_e) = a - b y_e with b = b'/(1-b')
// and a = a'/(1-b') (the paper's identity read backwards), the final density is nu_i (1 + b),
// so dnu/nu_i = b = -dDelta y/dy_e, and the predicted final profile equals the measured one.
TEST(Analysis, CollapseIdentityAndFinalDensityFromInitialDensity) {
  const auto scan = collapse_scan();
  const double a_prime = 1.9, b_prime = 0.39;
  const double b = b_prime / (1.0 - b_prime), a = a_prime / (1.0 - b_prime);
  // Uniform random centres at volume fraction 0.35.
  std::uniform_real_distribution<double> uy(1.0, 119.0);
  const auto results = synthetic_ensemble(
      scan, 7, [](const Member&) { return static_cast<int>(0.35 * 200.0 * 118.0 / M_PI); },
      [&](const Member&, std::mt19937_64& rng) {
        const double yi = uy(rng);
        return std::pair(yi, yi + a_prime - b_prime * yi);
      });
  const auto points = aggregate(scan, results);
  const Analysis an = analyse(scan, points);
  const PointAnalysis& p = an.points.at(0);
  ASSERT_TRUE(p.dy_by_ye.valid());
  ASSERT_TRUE(p.dy_by_yi.valid());
  // Exact lines: the fits use each bin's mean position, so exact data give exact bin means.
  EXPECT_NEAR(-p.dy_by_ye.coef[1], b, 1e-9);
  EXPECT_NEAR(p.dy_by_ye.coef[0], a, 1e-7);
  EXPECT_NEAR(p.b_prime, b_prime, 1e-9);
  EXPECT_NEAR(p.b_prime_predicted, b_prime, 1e-9);
  EXPECT_NEAR(p.a_prime_predicted, a_prime, 1e-7);
  // Exact lines in every member: the identity's differences vanish, and so do their jackknife
  // errors (every replica obeys it too), where the combined errors of the coefficients would not.
  EXPECT_NEAR(p.b_prime_difference, 0.0, 1e-9);
  EXPECT_NEAR(p.a_prime_difference, 0.0, 1e-7);
  EXPECT_LT(p.b_prime_difference_error, 1e-9);
  EXPECT_LT(p.a_prime_difference_error, 1e-7);
  // Members that collapse by different amounts (b' from 0.32 to 0.46), each along its exact line:
  // the pooled lines move together from member to member, so the jackknife error of b' - b/(1+b)
  // is smaller than the two coefficients' errors combined. (The pooled lines of such members
  // need not obey the identity that each member obeys: the bins mix members, and b/(1+b) is not
  // linear in b; here they miss it by about three of its errors, the reduced collapse's case in
  // docs/REPRODUCTION.md.)
  const auto varied = synthetic_ensemble(
      scan, 7, [](const Member&) { return static_cast<int>(0.35 * 200.0 * 118.0 / M_PI); },
      [&](const Member& m, std::mt19937_64& rng) {
        const double bm = b_prime + 0.02 * (m.seed_index - 3.5);
        const double yi = uy(rng);
        return std::pair(yi, yi + a_prime - bm * yi);
      });
  const auto vpoints = aggregate(scan, varied);
  const Analysis van = analyse(scan, vpoints);
  const PointAnalysis& v = van.points.at(0);
  ASSERT_GT(v.b_prime_error, 1e-3);
  EXPECT_GT(v.b_prime_difference_error, 0.0);
  EXPECT_LT(v.b_prime_difference_error, std::hypot(v.b_prime_error, v.b_prime_predicted_error));
  // The relative increase of the measured bulk densities equals the slope, within the
  // ensemble's error (the densities are random).
  const double tol = 4.0 * points[0].relative_increase.sem;
  EXPECT_NEAR(points[0].relative_increase.mean, p.slope_increase, tol);
  // Final density from the initial density (the deposition density of C): within a few
  // percent of the measured profile over the bulk.
  int compared = 0;
  for (std::size_t k = 0; k < points[0].nu.centre.size(); ++k) {
    if (!std::isfinite(p.nu_predicted[k])) continue;
    const double y = points[0].nu.centre[k];
    if (y < 10.0 || y > 60.0) continue;
    // Within four standard errors of the measured mean, and of the exact nu_i (1 + b) within
    // the scatter of the fitted power law (a few percent).
    EXPECT_NEAR(p.nu_predicted[k], points[0].nu.mean[k], 4.0 * points[0].nu.sem[k]) << "y " << y;
    EXPECT_NEAR(p.nu_predicted[k], 0.35 * (1.0 + b), 0.05 * 0.35 * (1.0 + b)) << "y " << y;
    ++compared;
  }
  EXPECT_GE(compared, 8);
}

// A synthetic protocol-A ensemble at three heights: disks deposited with the power-law density
// nu_d(y_i) = A y_i^p end at the y_e of the slice model, Delta y(y_e) = -alpha y_e (1 - y_e/H),
// whose curvature alpha/H falls like 1/H (the paper's fig. 7). Then the fitted parabola is
// (0, -alpha, alpha/H) at every H, the fit across heights gives the exponent -1, the deposition
// power law has the exponent p, and the final density predicted from it,
// nu_d(y_i(y_e)) (1 - dDelta y/dy_e), is the measured one (change of variables).
TEST(Analysis, AvalancheParabolaScalesLikeOneOverHeightAndPredictsTheFinalDensity) {
  const auto scan = parse_scan(R"(
[scan]
protocol = "A"
seeds = 16
[system]
width = 200.0
height = [60.0, 120.0, 240.0]
bond_number = 1000
[observables]
lower_half_from = 8.0
)",
                               "synthetic.toml");
  const double alpha = 0.2, p = -0.15, q = p + 1.0, nu_mean = 0.4;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const auto results = synthetic_ensemble(
      scan, 11,
      [&](const Member& m) {
        return static_cast<int>(nu_mean * m.params.width * (m.params.height - 2.0) / M_PI);
      },
      [&](const Member& m, std::mt19937_64& rng) {
        // Inverse of the cumulative distribution of y^p on [1, H - 1].
        const double H = m.params.height, lo = std::pow(1.0, q), hi = std::pow(H - 1.0, q);
        const double yi = std::pow(lo + u(rng) * (hi - lo), 1.0 / q);
        return std::pair(yi, slice_model_final_height(yi, alpha, H));
      });
  const auto points = aggregate(scan, results);
  const Analysis an = analyse(scan, points);
  ASSERT_EQ(an.points.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    const double H = points[k].point.params.height;
    const PointAnalysis& a = an.points[k];
    ASSERT_TRUE(a.dy_by_ye.valid()) << "H " << H;
    // Exact displacements: only the spread of y_e within a bin (a constant c w^2/12 in the mean
    // of c y_e^2) separates the bin means from the parabola, so c1 and c2 come out within 1 %.
    EXPECT_NEAR(a.dy_by_ye.coef[2], alpha / H, 0.01 * alpha / H) << "H " << H;
    EXPECT_NEAR(a.dy_by_ye.coef[1], -alpha, 0.01 * alpha) << "H " << H;
    ASSERT_TRUE(a.slice_parabola.valid());
    EXPECT_NEAR(a.slice_parabola.coef[0], alpha, 0.01 * alpha) << "H " << H;
    // The deposition density is random: its exponent within three of the fit's errors (and the
    // error itself a few hundredths: the test resolves the exponent).
    ASSERT_TRUE(a.deposition_power_law.valid());
    EXPECT_NEAR(a.deposition_power_law.coef[1], p, 3.0 * a.deposition_power_law.error[1]);
    EXPECT_LT(a.deposition_power_law.error[1], 0.05);
    // The prediction against the measured strips. If it is right, each z is a residual over
    // its standard error from n = 16 members, which inflates E z^2 to (n-1)/(n-3); neighbouring
    // strips share disks, so the k z's are correlated, at most pairwise with |rho| <= 1, and
    // chi2 has mean k and a variance of at most 3 (2k): as 3 chi2 of k/3 degrees of freedom
    // (Satterthwaite). The bound is that distribution's 99.9 % quantile (Wilson-Hilferty). The
    // control: the prediction without its slope factor (1 - dDelta y/dy_e), wrong by up to 20 %
    // here, lies beyond it.
    int compared = 0;
    double chi2 = 0.0, chi2_wrong = 0.0;
    const double c1 = a.dy_by_ye.coef[1], c2 = a.dy_by_ye.coef[2];
    for (std::size_t s = 0; s < points[k].nu.centre.size(); ++s) {
      const double y = points[k].nu.centre[s];
      if (!std::isfinite(a.nu_predicted[s]) || y < 10.0 || y > H - 10.0) continue;
      const double sem = points[k].nu.sem[s], measured = points[k].nu.mean[s];
      chi2 += std::pow((a.nu_predicted[s] - measured) / sem, 2);
      const double wrong = a.nu_predicted[s] / (1.0 - (c1 + 2.0 * c2 * y));
      chi2_wrong += std::pow((wrong - measured) / sem, 2);
      ++compared;
    }
    EXPECT_GE(compared, static_cast<int>(H / 8.0)) << "H " << H;
    const double dof = compared / 3.0, w = 2.0 / (9.0 * dof), z999 = 3.0902;
    const double bound = 3.0 * dof * std::pow(1.0 - w + z999 * std::sqrt(w), 3) * 15.0 / 13.0;
    std::printf(
        "H = %g: chi2 %.1f of the prediction, %.1f without the slope factor, bound %.1f "
        "(%d strips)\n",
        H, chi2, chi2_wrong, bound, compared);
    EXPECT_LT(chi2, bound) << "H " << H;
    EXPECT_GT(chi2_wrong, bound) << "H " << H;
  }
  // Across the heights: |c| = A H^p with p = -1 and A = alpha.
  const Fit& f = an.scan.quadratic_vs_height;
  ASSERT_TRUE(f.valid());
  EXPECT_EQ(f.scan_points, (std::vector<int>{0, 1, 2}));
  EXPECT_NEAR(f.coef[1], -1.0, 0.02);
  EXPECT_NEAR(std::exp(f.coef[0]), alpha, 0.05 * alpha);
  // And the slice model's a is alpha at every height: exponent 0.
  const Fit& fa = an.scan.slice_vs_height;
  ASSERT_TRUE(fa.valid());
  EXPECT_NEAR(fa.coef[1], 0.0, 0.02);
  EXPECT_NEAR(std::exp(fa.coef[0]), alpha, 0.05 * alpha);
}

// The laws across heights are those of cohesive avalanches: in a scan of Bo = 0 and 1e3 at three
// heights each, the fits go through the three cohesive points (the cohesionless group, first in
// the scan, has as many heights but a profile that is a constant shift, no curvature to scale).
TEST(Analysis, LawsAcrossHeightsUseTheCohesivePoints) {
  const Scan scan = parse_scan(R"(
[scan]
protocol = "A"
seeds = 4
[system]
width = 40.0
height = [60.0, 120.0, 240.0]
bond_number = [0, 1000]
[observables]
lower_half_from = 8.0
)",
                               "synthetic.toml");
  const double alpha = 0.2;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.05);
  const auto results = synthetic_ensemble(
      scan, 3,
      [&](const Member& m) {
        return static_cast<int>(0.4 * m.params.width * (m.params.height - 2.0) / M_PI);
      },
      [&](const Member& m, std::mt19937_64& rng) {
        const double H = m.params.height, yi = 1.0 + u(rng) * (H - 2.0);
        if (m.params.bond_number == 0.0) return std::pair(yi, yi - 0.5 + noise(rng));
        return std::pair(yi, slice_model_final_height(yi, alpha, H));
      });
  const auto points = aggregate(scan, results);
  std::vector<int> cohesive;
  for (const auto& p : points)
    if (p.point.params.bond_number == 1000.0) cohesive.push_back(p.point.index);
  ASSERT_EQ(cohesive.size(), 3u);
  const Analysis an = analyse(scan, points);
  for (const Fit* f : {&an.scan.quadratic_vs_height, &an.scan.slice_vs_height}) {
    ASSERT_TRUE(f->valid());
    EXPECT_EQ(f->scan_points, cohesive);
  }
  EXPECT_NEAR(an.scan.quadratic_vs_height.coef[1], -1.0, 0.05);
}

// The predicted intercept a/(1+b) of the y_i line comes from a and b of one fit, which are
// correlated. Members whose collapses differ in b' but share a' (Delta y(y_i) = a' - b'_m y_i)
// each have a/(1+b) = a', so its error is small (a fifth of the other's here), where propagating
// a's and b's errors as if independent gives a sizeable one. Members that share b' and differ in a'
// give a/(1+b) the scatter of a', which both ways see.
PointAnalysis collapse_of_members(double a_spread, double b_spread) {
  const auto scan = collapse_scan();
  std::mt19937_64 member_rng(5);
  std::normal_distribution<double> a_noise(0.0, a_spread), b_noise(0.0, b_spread);
  std::vector<double> a_of, b_of;  // by member id
  for (const Member& m : members_of(scan)) {
    a_of.resize(m.id + 1);
    b_of.resize(m.id + 1);
    a_of[m.id] = 1.9 + a_noise(member_rng);
    b_of[m.id] = 0.39 + b_noise(member_rng);
  }
  std::uniform_real_distribution<double> uy(1.0, 119.0);
  const auto results = synthetic_ensemble(
      scan, 7, [](const Member&) { return static_cast<int>(0.35 * 200.0 * 118.0 / M_PI); },
      [&](const Member& m, std::mt19937_64& rng) {
        const double yi = uy(rng);
        return std::pair(yi, yi + a_of[m.id] - b_of[m.id] * yi);
      });
  return analyse(scan, aggregate(scan, results)).points.at(0);
}

double independent_propagation(const PointAnalysis& p) {
  const double b = -p.dy_by_ye.coef[1], a = p.dy_by_ye.coef[0];
  return std::hypot(p.dy_by_ye.error[0] / (1.0 + b),
                    a * p.dy_by_ye.error[1] / ((1.0 + b) * (1.0 + b)));
}

TEST(Analysis, ThePredictedInterceptsErrorHoldsTheCorrelationOfItsFitsCoefficients) {
  const PointAnalysis shared_a = collapse_of_members(0.0, 0.03);
  // The pooled bins mix the members' lines, so a/(1+b) is a' only within its error.
  EXPECT_NEAR(shared_a.a_prime_predicted, 1.9, 2.0 * shared_a.a_prime_predicted_error);
  EXPECT_LT(shared_a.a_prime_predicted_error, 0.3 * independent_propagation(shared_a));
  const PointAnalysis shared_b = collapse_of_members(0.3, 0.0);
  EXPECT_NEAR(shared_b.a_prime_predicted_error, independent_propagation(shared_b),
              0.1 * independent_propagation(shared_b));
}

// A power law through data whose x is measured with an error correlated with y's (as a collapse's
// nu_i and dnu/nu_i are, on the same members): in logs, x's error 0.0104 and y's 0.026, y's
// mostly the x fluctuation carried along a steeper line (correlation -0.95), the law's exponent
// -1.76 (the sizes of fig. 17's points at the paper's size, 4 members each). Over 400 sets of 5
// such points the effective-variance fit's chi2/dof averages 1 (3 dof: its mean's standard error
// 0.041 over 400 sets; bounds at 4 of them) and its 95 % interval holds the exponent in 95 % of
// the sets (the binomial's standard deviation 0.011; bounds at 4 of them). The fit with y's
// errors alone weighs each datum by an error 2.5 times too large: its mean chi2/dof falls below
// the bound. Without x errors the fit is the weighted one.
TEST(Analysis, PowerLawWithCorrelatedErrorsInXIsCalibrated) {
  const std::vector<double> x0 = {0.20, 0.25, 0.30, 0.35, 0.40};
  const double p = -1.76, lnA = std::log(0.127), sx = 0.0104, sy = 0.026, rho = -0.95;
  const double c = rho * sx * sy;
  std::mt19937_64 rng(17);
  std::normal_distribution<double> normal;
  double chi2 = 0.0, chi2_plain = 0.0;
  int covered = 0;
  const int sets = 400;
  for (int k = 0; k < sets; ++k) {
    std::vector<double> x, y, sigma, sigma_x, cov;
    for (double xt : x0) {
      const double e1 = normal(rng), e2 = normal(rng);
      const double dx = sx * e1, dy = sy * (rho * e1 + std::sqrt(1.0 - rho * rho) * e2);
      x.push_back(xt * std::exp(dx));
      y.push_back(std::exp(lnA + p * std::log(xt) + dy));
      sigma.push_back(sy * y.back());
      sigma_x.push_back(sx * x.back());
      cov.push_back(c * x.back() * y.back());
    }
    const Fit f = power_law_fit(x, y, sigma, sigma_x, cov);
    const Fit plain = power_law_fit(x, y, sigma);
    ASSERT_TRUE(f.valid() && plain.valid());
    chi2 += f.reduced_chi2() / sets;
    chi2_plain += plain.reduced_chi2() / sets;
    covered += std::fabs(f.coef[1] - p) <= 1.96 * f.error[1];
  }
  EXPECT_NEAR(chi2, 1.0, 4.0 * std::sqrt(2.0 / 3.0 / sets));
  EXPECT_NEAR(covered / double(sets), 0.95, 4.0 * std::sqrt(0.95 * 0.05 / sets));
  EXPECT_LT(chi2_plain, 1.0 - 4.0 * std::sqrt(2.0 / 3.0 / sets));
  // No error in x: the weighted fit in logs.
  const std::vector<double> x = {0.2, 0.3, 0.4}, y = {1.3, 0.6, 0.4}, s = {0.05, 0.03, 0.02};
  const Fit a = power_law_fit(x, y, s, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}),
            b = power_law_fit(x, y, s);
  ASSERT_TRUE(a.valid());
  EXPECT_EQ(a.coef, b.coef);
  EXPECT_EQ(a.error, b.error);
}

// Protocol C at three capture radii, with initial densities nu_i set per point and uniform
// collapses of relative increase b = K nu_i^s: the fit of dnu/nu_i against the measured nu_i
// across the points (the paper's fig. 17) recovers the exponent s. The scan's first point has
// another height (as in a file that runs fig. 16's heights first): the three radii are still
// found together.
TEST(Analysis, RelativeIncreaseAgainstInitialDensityIsAPowerLaw) {
  const auto scan = parse_scan(R"(
[scan]
protocol = "C"
seeds = 8
[system]
width = 200.0
bond_number = 1000
[observables]
lower_half_from = 8.0
[[point]]
height = 60.0
capture_radius = 1.0
[[point]]
height = 120.0
capture_radius = 1.0
[[point]]
height = 120.0
capture_radius = 1.5
[[point]]
height = 120.0
capture_radius = 2.0
[[point]]
height = 120.0
capture_radius = 1.25
)",
                               "synthetic.toml");
  const double nu_i[5] = {0.40, 0.40, 0.33, 0.27, 0.37};
  const double height[5] = {60.0, 120.0, 120.0, 120.0, 120.0};
  const double K = 0.1, s = -1.64;
  const auto results = synthetic_ensemble(
      scan, 13,
      [&](const Member& m) {
        return static_cast<int>(nu_i[m.point] * 200.0 * (height[m.point] - 2.0) / M_PI);
      },
      [&](const Member& m, std::mt19937_64& rng) {
        const double b = K * std::pow(nu_i[m.point] / 0.33, s);
        const double b_prime = b / (1.0 + b);  // y_e = (1 - b') y_i compresses by 1 + b
        std::uniform_real_distribution<double> uy(1.0, height[m.point] - 1.0);
        const double yi = uy(rng);
        return std::pair(yi, (1.0 - b_prime) * yi);
      });
  const auto points = aggregate(scan, results);
  const Analysis an = analyse(scan, points);
  const Fit& f = an.scan.increase_vs_nu_initial;
  ASSERT_TRUE(f.valid());
  EXPECT_EQ(f.scan_points, (std::vector<int>{1, 2, 3, 4}));  // not point 0, of another height
  EXPECT_NEAR(f.coef[1], s, 3.0 * f.error[1]);
  EXPECT_LT(f.error[1], 0.3);
  EXPECT_NEAR(std::exp(f.coef[0]) * std::pow(0.33, s), K, 0.1 * K);
  // nu_i's error and its covariance with dnu/nu_i come from the members: the sample variance of
  // nu_i and the sample covariance of nu_i and (nu_f - nu_i)/nu_i over the n members, each over
  // n, widened by (n - 1)/(n - 3) as sigma's square is. The fit is the effective-variance fit of
  // those numbers; without the members' nu_i (a file before 2026-12-05) it takes nu_i as exact.
  std::vector<double> x, y, sy, sx, cov;
  for (int k : f.scan_points) {
    const PointResult& p = points[static_cast<std::size_t>(k)];
    std::vector<double> ni, inc;
    for (std::size_t m = 0; m < p.m_nu_initial.size(); ++m) {
      ni.push_back(p.m_nu_initial[m]);
      inc.push_back((p.m_nu_lower_half[m] - ni.back()) / ni.back());
    }
    const double n = static_cast<double>(ni.size());
    const double mi = std::accumulate(ni.begin(), ni.end(), 0.0) / n;
    const double mc = std::accumulate(inc.begin(), inc.end(), 0.0) / n;
    double vi = 0.0, ci = 0.0;
    for (std::size_t m = 0; m < ni.size(); ++m) {
      vi += (ni[m] - mi) * (ni[m] - mi) / (n - 1.0);
      ci += (ni[m] - mi) * (inc[m] - mc) / (n - 1.0);
    }
    const double widen = (n - 1.0) / (n - 3.0);
    x.push_back(p.nu_initial.mean);
    y.push_back(p.relative_increase.mean);
    sy.push_back(p.relative_increase.sem * std::sqrt(widen));
    sx.push_back(std::sqrt(vi / n * widen));
    cov.push_back(ci / n * widen);
  }
  const Fit expected = power_law_fit(x, y, sy, sx, cov);
  ASSERT_TRUE(expected.valid());
  EXPECT_NEAR(f.coef[1], expected.coef[1], 1e-9);
  EXPECT_NEAR(f.error[1], expected.error[1], 1e-9);
  auto without_members = points;
  for (auto& p : without_members) p.m_nu_initial.clear();
  const Fit exact_x = analyse(scan, without_members).scan.increase_vs_nu_initial;
  ASSERT_TRUE(exact_x.valid());
  EXPECT_NEAR(exact_x.coef[1], power_law_fit(x, y, sy).coef[1], 1e-9);
  EXPECT_GT(std::fabs(exact_x.coef[1] - f.coef[1]), 1e-6);  // the covariance matters here
  // The members' nu_i (for nu_i's error and its covariance with dnu/nu_i) travel in the file:
  // `loosepack analyse` fits the same law.
  {
    const run_helpers::TempDir dir;
    write_results(dir / "c.h5", scan, RunInfo{}, points, an, results, false);
    reanalyse(dir / "c.h5", dir / "again.h5");
    EXPECT_EQ(read_dataset(dir / "again.h5", "analysis/increase_vs_nu_initial/coef"), f.coef);
    EXPECT_EQ(read_dataset(dir / "again.h5", "analysis/increase_vs_nu_initial/error"), f.error);
  }
  // The fit names the points by their index (K of points/K), also where a file holds only some
  // of the scan's points (a shard, a run stopped early): here without point 0.
  const std::vector<PointResult> held(points.begin() + 1, points.end());
  EXPECT_EQ(analyse(scan, held).scan.increase_vs_nu_initial.scan_points,
            (std::vector<int>{1, 2, 3, 4}));
  // A point of one finished member has no error: it takes no part in the fit, neither listed
  // among its points nor switching its chi2 off (as a datum of 3 or fewer members does).
  auto one_member = points;
  one_member[1].relative_increase.n = 1;
  one_member[1].relative_increase.sem = std::numeric_limits<double>::quiet_NaN();
  const Analysis without = analyse(scan, one_member);
  const Fit& g = without.scan.increase_vs_nu_initial;
  ASSERT_TRUE(g.valid());
  EXPECT_EQ(g.scan_points, (std::vector<int>{2, 3, 4}));
  EXPECT_TRUE(std::isfinite(g.chi2));
  // With two such points only two data are left: a law of two parameters through two points has
  // no degree of freedom to be tested by, and is not fitted.
  one_member[4].relative_increase.n = 1;
  one_member[4].relative_increase.sem = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(analyse(scan, one_member).scan.increase_vs_nu_initial.valid());
  // A datum within three errors of zero has an ln y its error sigma / y does not describe
  // (here 2.5 errors), and a point whose disks moved by less than the event threshold on average
  // one whose error is round-off: neither takes part.
  auto unresolved = points;
  unresolved[2].relative_increase.sem = unresolved[2].relative_increase.mean / 2.5;
  unresolved[3].relative_increase = {1e-15, 1e-16, 8};
  unresolved[3].mean_abs_dy.mean = 1e-13;
  const Fit& u = analyse(scan, unresolved).scan.increase_vs_nu_initial;
  EXPECT_FALSE(u.valid());  // two points left, 1 and 4
  unresolved[2] = points[2];
  EXPECT_EQ(analyse(scan, unresolved).scan.increase_vs_nu_initial.scan_points,
            (std::vector<int>{1, 2, 4}));
  // Points that differ in another parameter too (here the disks' density) are no series in
  // r_capt: two points are left, too few for the fit.
  auto denser = points;
  denser[1].point.params.disk_density *= 2.0;
  denser[4].point.params.disk_density *= 2.0;
  EXPECT_FALSE(analyse(scan, denser).scan.increase_vs_nu_initial.valid());
}

// The errors of a profile fit are a jackknife over members. When every member has its disks at
// the same y_e (so every bin has the same position and count in every member), the pooled bin
// means are the averages of the members' bin means and the unweighted fit is linear in them:
// the pooled fit's coefficients are the means of the members' own fits, and the jackknife error
// is exactly the standard error of those across members, sqrt(sum (c_m - mean c)^2 / (n (n-1))).
// Each member here has its own curvature, so that error is the member-to-member scatter.
TEST(Analysis, ProfileErrorsAreAJackknifeOverMembers) {
  const auto scan = profile_scan(6, 100);
  const double H = 80.0;
  const int n = 800;
  int k = 0;  // disk index within the member
  std::normal_distribution<double> noise(0.0, 0.2), spread(0.0, 0.3);
  std::vector<double> alpha;  // each member's slice-model coefficient
  const auto results = synthetic_ensemble(
      scan, 23,
      [&](const Member&) {
        k = 0;
        alpha.push_back(0.0);
        return n;
      },
      [&](const Member&, std::mt19937_64& rng) {
        if (k == 0) alpha.back() = 0.15 * (1.0 + spread(rng));
        const double ye = 1.0 + (k++ + 0.5) * (H - 2.0) / n;
        return std::pair(ye + alpha.back() * ye * (1.0 - ye / H) + noise(rng), ye);
      });
  const auto points = aggregate(scan, results);
  const BinnedStat& b = points.at(0).dy_by_ye;
  ASSERT_EQ(b.member_mean.size(), 6u);
  // The members' own unweighted fits to their bin means.
  std::vector<std::vector<double>> member_coef;
  for (std::size_t m = 0; m < b.member_mean.size(); ++m) {
    const Fit f = polynomial_fit(b.member_position[m], b.member_mean[m], {}, 2);
    ASSERT_TRUE(f.valid());
    member_coef.push_back(f.coef);
  }
  const Fit fit = analyse(scan, points).points.at(0).dy_by_ye;
  ASSERT_TRUE(fit.valid());
  ASSERT_EQ(fit.points, 20);  // every bin is used, so the members' fits use the same bins
  for (std::size_t j = 0; j < 3; ++j) {
    double mean = 0.0, ss = 0.0;
    for (const auto& c : member_coef) mean += c[j] / 6.0;
    for (const auto& c : member_coef) ss += (c[j] - mean) * (c[j] - mean);
    const double sem = std::sqrt(ss / (6.0 * 5.0));
    EXPECT_NEAR(fit.coef[j], mean, 1e-9 * (std::fabs(mean) + sem)) << "coefficient " << j;
    EXPECT_NEAR(fit.error[j], sem, 1e-6 * sem) << "coefficient " << j;
  }
  // The curvature is alpha/H (Delta y = -alpha y_e + (alpha/H) y_e^2) with alpha the members' mean,
  // within the error.
  double mean_alpha = 0.0;
  for (double a : alpha) mean_alpha += a / 6.0;
  EXPECT_NEAR(fit.coef[2], mean_alpha / H, 4.0 * fit.error[2]);
  // Every member's profile is a parabola, so the residuals are the disks' noise, and chi2 is
  // against their jackknife errors (each a t of 5 degrees of freedom, errors estimated from
  // n = 6 members, mapped to its chi2 term): about 1 per degree of freedom. Against the bins'
  // standard errors, which hold the members' different curvatures, it would be far below 1.
  EXPECT_GT(fit.reduced_chi2(), 0.5);
  EXPECT_LT(fit.reduced_chi2(), 4.0);
}

// A fit of the true model has chi2/dof near 1 and is rejected at the 99 % bound about once in a
// hundred: 200 ensembles of 8 members of 1 000 disks, Delta y = -alpha y_e (1 - y_e/H) plus disk
// noise. The sum of each residual's term against its own jackknife error has the expectation of
// the bins (20), not of the degrees of freedom (17): without the factor 17/20 the mean here is
// 1.14 and 5 of the 200 fits are rejected (2 with it). The term the parabola lacks, the cubic's
// coefficient over its jackknife error, is beyond Student's two-sided 99 % quantile for 7 degrees
// of freedom (3.4995) about as often.
TEST(Analysis, AProfileFitOfTheTrueModelHasChi2PerDegreeOfFreedomNearOne) {
  const auto scan = profile_scan(8, 1000);
  const double H = 80.0, alpha = 0.3;
  std::normal_distribution<double> noise(0.0, 0.3);
  std::uniform_real_distribution<double> uy(1.0, H - 1.0);
  double sum = 0.0;
  int rejected = 0, next_term = 0, fits = 0;
  for (int e = 0; e < 200; ++e) {
    const auto results = synthetic_ensemble(
        scan, 7000 + e, [](const Member&) { return 1000; },
        [&](const Member&, std::mt19937_64& rng) {
          const double ye = uy(rng);
          return std::pair(ye + alpha * ye * (1.0 - ye / H) + noise(rng), ye);
        });
    const Fit fit = analyse(scan, aggregate(scan, results)).points.at(0).dy_by_ye;
    ASSERT_TRUE(fit.valid() && std::isfinite(fit.chi2));
    ASSERT_EQ(fit.dof, 17);
    sum += fit.reduced_chi2();
    rejected += fit.chi2 > chi2_quantile99(fit.dof) ? 1 : 0;
    ASSERT_TRUE(std::isfinite(fit.next_term_t));
    next_term += std::fabs(fit.next_term_t) > 3.4995 ? 1 : 0;
    ++fits;
  }
  const double mean = sum / fits;
  std::printf("mean chi2/dof %.3f, rejected at the 99 %% bound %d of %d\n", mean, rejected, fits);
  // chi2/dof of 17 dof has variance 2/17: the mean of 200 has a standard error of 0.024, and
  // 0.1 is four of them.
  EXPECT_NEAR(mean, 1.0, 4.0 * std::sqrt(2.0 / 17.0 / 200.0));
  EXPECT_LE(rejected, binomial_quantile(200, 0.01, 0.999));  // 8 (2 expected)
  std::printf("next term beyond its 99 %% bound %d of %d\n", next_term, fits);
  EXPECT_LE(next_term, binomial_quantile(200, 0.01, 0.999));
}

// The term a model lacks shows where the profile has it: 8 members whose Delta y(y_e) has a cubic
// part of 1.5 R at the top of the box give the parabola's next term a t beyond its 99 % bound
// (-6.0 here).
TEST(Analysis, AProfileFitShowsTheTermItLacks) {
  const auto scan = profile_scan(8, 1000);
  const double H = 80.0, alpha = 0.3;
  std::normal_distribution<double> noise(0.0, 0.3);
  std::uniform_real_distribution<double> uy(1.0, H - 1.0);
  const auto results = synthetic_ensemble(
      scan, 99, [](const Member&) { return 1000; },
      [&](const Member&, std::mt19937_64& rng) {
        const double ye = uy(rng), u = ye / H;
        return std::pair(ye + alpha * ye * (1.0 - u) + 1.5 * u * u * u + noise(rng), ye);
      });
  const Fit fit = analyse(scan, aggregate(scan, results)).points.at(0).dy_by_ye;
  EXPECT_GT(std::fabs(fit.next_term_t), 3.4995);
}

// Student's t quantiles (two-sided 1 %: t = 5.8409 at 3 degrees of freedom, 3.4995 at 7, 2.9467
// at 15) map to the normal's, 2.5758; a t of 0 to 0.
TEST(Analysis, AStudentTMapsToTheNormalDeviateOfItsTailProbability) {
  for (const auto& [nu, t] :
       {std::pair(3.0, 5.8409), std::pair(7.0, 3.4995), std::pair(15.0, 2.9467)})
    EXPECT_NEAR(std::sqrt(chi2_term_of_t(t, nu)), 2.5758, 0.02 * 2.5758) << nu << " dof";
  EXPECT_EQ(chi2_term_of_t(0.0, 7.0), 0.0);
}

// A sum of 38 terms of t with errors from n members (t with n - 1 degrees of freedom) exceeds
// chi2's 99 % quantile once in a hundred at 8 and 16 members, and a little less often at 4
// (0.7 %: Wallace's deviate falls short of the exact one in the far tail of t with 3 degrees of
// freedom, by 1 % at t = 5): 20 000 sums each. The sum of t^2 scaled by (n-3)/(n-1), which has
// chi2's mean but a heavier tail, exceeds it 2 % of the time at 16 members, 4 % at 8 and 9 % at 4
// (the same draws).
TEST(Analysis, TermsOfStudentsTSumToChi2InTheTail) {
  const double bound = chi2_quantile99(38.0);
  for (const double n : {4.0, 8.0, 16.0}) {
    std::mt19937_64 rng(static_cast<std::uint64_t>(n));
    std::student_t_distribution<double> t(n - 1.0);
    int over = 0, over_scaled = 0;
    for (int e = 0; e < 20000; ++e) {
      double sum = 0.0, sum_t2 = 0.0;
      for (int i = 0; i < 38; ++i) {
        const double v = t(rng);
        sum += chi2_term_of_t(v, n - 1.0);
        sum_t2 += v * v;
      }
      over += sum > bound ? 1 : 0;
      over_scaled += sum_t2 * (n - 3.0) / (n - 1.0) > bound ? 1 : 0;
    }
    std::printf("%g members: over the 99 %% bound %d of 20000; scaled sum of t^2 %d\n", n, over,
                over_scaled);
    // 200 expected; the binomial's 99.9 % range is about 158-246.
    if (n >= 8.0) {
      EXPECT_GE(over, binomial_quantile(20000, 0.01, 0.001)) << n << " members";
    }
    EXPECT_LE(over, binomial_quantile(20000, 0.01, 0.999)) << n << " members";
    if (n < 16.0) {
      EXPECT_GT(over_scaled, binomial_quantile(20000, 0.01, 0.999)) << n << " members";
    }
  }
}

// A law across scan points, fitted to means whose errors come from few members, is rejected at
// the 99 % bound about once in a hundred: 500 scans of protocol C at six heights, 4 members
// each, every member's relative increase b = 0.1 + 0.05 ln H plus member noise of 0.03. Each
// point's standard error comes from its 4 members' scatter, so (b - law)/sem follows Student's t
// with 3 degrees of freedom; without the errors widened by sqrt(3/1) a true law is rejected about
// 12 % of the time (a simulation of the same fit gives 12.4 %, and 1.4 % widened; its mean
// chi2/dof widened is 0.64, the t's heavy tails).
TEST(Analysis, ALawAcrossPointsWithErrorsFromFewMembersIsRejectedOnceInAHundred) {
  const auto scan = parse_scan(R"(
[scan]
protocol = "C"
seeds = 4
[system]
width = 20.0
bond_number = 1000
[observables]
lower_half_from = 4.0
[[point]]
height = 20.0
[[point]]
height = 30.0
[[point]]
height = 45.0
[[point]]
height = 60.0
[[point]]
height = 90.0
[[point]]
height = 120.0
)",
                               "synthetic.toml");
  const std::vector<Member> members = members_of(scan);
  std::mt19937_64 noise_rng(11);
  std::normal_distribution<double> noise(0.0, 0.03);
  double sum = 0.0;
  int rejected = 0, fits = 0;
  for (int e = 0; e < 500; ++e) {
    std::vector<double> b_of(members.size());  // by member id
    for (const Member& m : members)
      b_of[m.id] = 0.1 + 0.05 * std::log(m.params.height) + noise(noise_rng);
    const auto results = synthetic_ensemble(
        scan, 9000 + e,
        [](const Member& m) {
          return static_cast<int>(0.4 * m.params.width * (m.params.height - 2.0) / M_PI);
        },
        [&](const Member& m, std::mt19937_64& rng) {
          std::uniform_real_distribution<double> uy(1.0, m.params.height - 1.0);
          const double yi = uy(rng);
          return std::pair(yi, yi / (1.0 + b_of[m.id]));  // a uniform compression by 1 + b
        });
    const Fit f = analyse(scan, aggregate(scan, results)).scan.increase_vs_log_height;
    ASSERT_TRUE(f.valid() && std::isfinite(f.chi2));
    ASSERT_EQ(f.dof, 4);
    sum += f.reduced_chi2();
    rejected += f.chi2 > chi2_quantile99(f.dof) ? 1 : 0;
    ++fits;
  }
  const double mean = sum / fits;
  std::printf("mean chi2/dof %.3f, rejected at the 99 %% bound %d of %d\n", mean, rejected, fits);
  EXPECT_LE(rejected, binomial_quantile(500, 0.01, 0.999));  // 13 (5 expected; 60 at 12 %)
}

// A profile whose lower half does not move (Delta y = 0 up to a creep of 1e-5 R) and whose upper
// half does, Delta y = -alpha (y_e - H/2) (1 - y_e/H) with disk noise 0.3 R. The still bins have
// errors ten thousand times smaller than the moving ones'. A weighted fit passes through them
// and bends away from the moving half; the program's fit is the unweighted one through every
// bin mean, whatever their errors.
TEST(Analysis, BinsThatDoNotMoveDoNotPinTheProfileFit) {
  const auto scan = profile_scan(8, 1000);
  const double H = 80.0, alpha = 0.4;
  std::normal_distribution<double> noise(0.0, 0.3), creep(0.0, 1e-5);
  std::uniform_real_distribution<double> uy(1.0, H - 1.0);
  const auto results = synthetic_ensemble(
      scan, 29, [](const Member&) { return 1000; },
      [&](const Member&, std::mt19937_64& rng) {
        const double ye = uy(rng);
        const double dy =
            ye < 0.5 * H ? creep(rng) : -alpha * (ye - 0.5 * H) * (1.0 - ye / H) + noise(rng);
        return std::pair(ye - dy, ye);
      });
  const auto points = aggregate(scan, results);
  const BinnedStat& b = points.at(0).dy_by_ye;
  std::vector<double> x, y, s;
  for (std::size_t k = 0; k < b.centre.size(); ++k) {
    x.push_back(b.position[k]);
    y.push_back(b.mean[k]);
    s.push_back(b.sem[k]);
  }
  const Fit unweighted = polynomial_fit(x, y, {}, 2);
  const Fit weighted = polynomial_fit(x, y, s, 2);
  const Fit fit = analyse(scan, points).points.at(0).dy_by_ye;
  ASSERT_TRUE(fit.valid() && unweighted.valid() && weighted.valid());
  ASSERT_EQ(fit.points, 20);
  for (std::size_t j = 0; j < 3; ++j)
    EXPECT_NEAR(fit.coef[j], unweighted.coef[j], 1e-9 * std::fabs(unweighted.coef[j]));
  // The case the test is about: the weighted curvature is far from the unweighted one.
  EXPECT_GT(std::fabs(weighted.coef[2] - unweighted.coef[2]), 5.0 * fit.error[2]);
  // The still bins sit off the parabola by far more than their residuals' jackknife errors: the
  // fit is rejected many times over (a term grows only like ln t^2 that far out in t's tail).
  EXPECT_GT(fit.chi2, 10.0 * chi2_quantile99(fit.dof));
}

// A bin's pooled mean weights each member by its disks there, so its standard error is that of a
// ratio over members: with one member of every eight holding ten times the others' disks, and each
// member's Delta y offset by its own N(0, 1), the pooled mean's variance across ensembles is
// (100 + 7) / 17^2 = 0.37 (disk noise aside), three times the 1/8 that the scatter of the members'
// unweighted means gives. The stored error squared matches that variance on average (the
// delete-one-member jackknife of the ratio).
TEST(Analysis, BinErrorsAreThoseOfThePooledMean) {
  const auto scan = profile_scan(8, 100);
  const double H = 80.0;
  constexpr int kEnsembles = 400;
  std::normal_distribution<double> offset(0.0, 1.0), noise(0.0, 0.3);
  std::vector<double> pooled, sem2;
  for (int e = 0; e < kEnsembles; ++e) {
    int member = 0;
    double shift = 0.0;
    const auto results = synthetic_ensemble(
        scan, 1000 + e,
        [&](const Member&) {
          shift = std::numeric_limits<double>::quiet_NaN();  // drawn with the member's first disk
          return member++ == 0 ? 800 : 80;
        },
        [&](const Member&, std::mt19937_64& rng) {
          if (std::isnan(shift)) shift = offset(rng);
          const double ye = std::uniform_real_distribution<double>(1.0, H - 1.0)(rng);
          return std::pair(ye - shift - noise(rng), ye);
        });
    const auto points = aggregate(scan, results);
    const BinnedStat& b = points.at(0).dy_by_ye;
    for (std::size_t u = 0; u < b.mean.size(); ++u) {
      if (b.count[u] == 0.0) continue;
      pooled.push_back(b.mean[u]);
      sem2.push_back(b.sem[u] * b.sem[u]);
    }
  }
  ASSERT_GT(pooled.size(), std::size_t(kEnsembles));
  // Every bin of an ensemble shares its members' offsets: the bins' variance is the offsets'.
  double mean = 0.0, var = 0.0, mean_sem2 = 0.0;
  for (double p : pooled) mean += p / pooled.size();
  for (double p : pooled) var += (p - mean) * (p - mean) / (pooled.size() - 1);
  for (double s : sem2) mean_sem2 += s / sem2.size();
  std::printf("pooled mean variance %.4f, mean squared error %.4f\n", var, mean_sem2);
  // 400 ensembles: the variance is known to about 7 % (sqrt(2/400)).
  EXPECT_NEAR(mean_sem2 / var, 1.0, 0.2);
  EXPECT_NEAR(var, 107.0 / 289.0, 0.2 * 107.0 / 289.0);
}

// The avalanche-event histograms' edges (docs/MODEL.md, "Observables"): logarithmic bins of 4 per
// decade from 1e-3 to 1e5; an event of more steps than the last edge is counted in the last bin;
// an event that moved disks only upwards is in the moved histogram but in neither the downward
// one nor `events_without_motion`; one that moved nothing is counted there only (its steps
// still binned).
TEST(Analysis, EventHistogramsKeepTheirEdgeRules) {
  const auto scan = profile_scan(2, 100);
  auto results = synthetic_ensemble(
      scan, 5, [](const Member&) { return 10; },
      [](const Member&, std::mt19937_64& rng) {
        const double y = std::uniform_real_distribution<double>(1.0, 79.0)(rng);
        return std::pair(y, y);
      });
  results[0].events = {{3, 0.0, 20, false},     // disks moved only upwards
                       {0, 0.0, 12, false},     // nothing moved
                       {5, 2.5, 200000, true},  // beyond the last edge (1e5 steps)
                       {1, 1e-4, 10, false}};   // below the first edge (1e-3 R)
  const PointResult pr = aggregate(scan, results).at(0);
  ASSERT_EQ(pr.event_edges.size(), 33u);
  EXPECT_DOUBLE_EQ(pr.event_edges.front(), 1e-3);
  EXPECT_DOUBLE_EQ(pr.event_edges.back(), 1e5);
  const auto bin = [&](double v) {  // the bin whose edges hold v (the first and last beyond)
    std::size_t j = 0;
    while (j + 1 < pr.event_edges.size() - 1 && pr.event_edges[j + 1] <= v) ++j;
    return j;
  };
  const auto total = [](const std::vector<double>& c) {
    return std::accumulate(c.begin(), c.end(), 0.0);
  };
  EXPECT_EQ(pr.events_without_motion, 1.0);
  EXPECT_EQ(total(pr.event_moved_counts), 3.0);
  EXPECT_EQ(pr.event_moved_counts[bin(3.0)], 1.0);
  EXPECT_EQ(pr.event_moved_counts[bin(5.0)], 1.0);
  EXPECT_EQ(pr.event_moved_counts[bin(1.0)], 1.0);
  EXPECT_EQ(total(pr.event_downward_counts), 2.0);  // not the upward event
  EXPECT_EQ(pr.event_downward_counts[bin(2.5)], 1.0);
  EXPECT_EQ(pr.event_downward_counts.front(), 1.0);  // 1e-4 R, below the first edge
  EXPECT_EQ(total(pr.event_steps_counts), 4.0);
  EXPECT_EQ(pr.event_steps_counts.back(), 1.0);  // 2e5 steps
  EXPECT_EQ(pr.event_steps_counts[bin(20.0)], 1.0);
}

// nu(y) has the whole strips of 3.97 R below H (H = 80: 20 strips, up to 79.4 R; a 21st would
// reach over H), each the exact disk area in it over its own: strip k holds k + 1 disks of radius
// 1 wholly inside it (at its middle), so nu_k = (k + 1) pi / (3.97 L_x).
TEST(Analysis, VolumeFractionProfileHasTheWholeStripsBelowH) {
  const auto scan = profile_scan(2, 100);
  const double strip = 3.97, width = 40.0;
  int k = 0, in_strip = 0;
  const auto results = synthetic_ensemble(
      scan, 9,
      [&](const Member&) {
        k = in_strip = 0;
        return 20 * 21 / 2;
      },
      [&](const Member&, std::mt19937_64&) {
        const double y = (k + 0.5) * strip;
        if (++in_strip == k + 1) {
          ++k;
          in_strip = 0;
        }
        return std::pair(y, y);
      });
  const PointResult pr = aggregate(scan, results).at(0);
  ASSERT_EQ(pr.nu.mean.size(), 20u);  // floor(80 / 3.97)
  for (std::size_t s = 0; s < 20; ++s)
    EXPECT_NEAR(pr.nu.mean[s], (s + 1.0) * M_PI / (strip * width), 1e-12) << "strip " << s;
}

// A bin enters the profile fits only where every member has disks: one member of four reaches
// only y_e = 40 (as after a deep collapse), so of the 20 bins of 4 R the 10 below 40 are used.
TEST(Analysis, ProfileFitsUseTheBinsEveryMemberReaches) {
  const auto scan = profile_scan(4, 100);
  std::normal_distribution<double> noise(0.0, 0.2);
  const auto results = synthetic_ensemble(
      scan, 31, [](const Member&) { return 1000; },
      [&](const Member& m, std::mt19937_64& rng) {
        const double top = m.seed_index == 0 ? 40.0 : 79.0;
        const double ye = std::uniform_real_distribution<double>(1.0, top)(rng);
        return std::pair(ye + 0.1 * ye * (1.0 - ye / 80.0) + noise(rng), ye);
      });
  const auto points = aggregate(scan, results);
  const Fit fit = analyse(scan, points).points.at(0).dy_by_ye;
  ASSERT_TRUE(fit.valid());
  EXPECT_EQ(fit.points, 10);
}

// The slice model leaves out the top cut_top of the box: there the last-deposited disks (the
// paper's "crust") have not moved, which the slice model does not describe. The control fits the
// same ensemble with the crust in (cut_top = 0), which must miss alpha: a crust of 20 R has the
// leverage to bend the fit (one of 6 R would not, as the model's -y (1 - y/H) vanishes at H).
TEST(Analysis, SliceModelLeavesOutTheCrust) {
  const double alpha = 0.1, H = 120.0, crust = 20.0;
  const auto slice_fit = [&](double cut_top) {
    const auto scan = parse_scan(R"(
[scan]
protocol = "A"
seeds = 8
[system]
width = 100.0
height = 120.0
bond_number = 1000
[observables]
lower_half_from = 4.0
cut_top = )" + std::to_string(cut_top) +
                                     "\n",
                                 "synthetic.toml");
    std::normal_distribution<double> noise(0.0, 0.5), creep(0.0, 1e-4);
    std::uniform_real_distribution<double> uy(1.0, H - 1.0);
    const auto results = synthetic_ensemble(
        scan, 17, [](const Member&) { return 1500; },
        [&](const Member&, std::mt19937_64& rng) {
          const double yi = uy(rng);
          const double ye = yi > H - crust ? yi + creep(rng)
                                           : slice_model_final_height(yi, alpha, H) + noise(rng);
          return std::pair(yi, ye);
        });
    return analyse(scan, aggregate(scan, results)).points.at(0).slice_parabola;
  };
  const Fit cut = slice_fit(crust + 4.0);
  ASSERT_TRUE(cut.valid());
  EXPECT_NEAR(cut.coef[0], alpha, 3.0 * cut.error[0]);
  EXPECT_LT(cut.error[0], 0.1 * alpha);
  const Fit with_crust = slice_fit(0.0);
  ASSERT_TRUE(with_crust.valid());
  EXPECT_GT(std::fabs(with_crust.coef[0] - alpha), 3.0 * with_crust.error[0]);
}
