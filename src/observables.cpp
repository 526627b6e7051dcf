// Per-member observables (MODEL.md, "Observables") and their ensemble aggregates.
#include "loosepack/observables.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "kernels/contact_law.hpp"
#include "loosepack/geometry.hpp"

namespace loosepack {

std::vector<double> volume_fraction_profile(const std::vector<double>& y,
                                            const std::vector<double>& r, double width,
                                            double strip, int n_strips) {
  std::vector<double> area(static_cast<std::size_t>(std::max(n_strips, 0)), 0.0);
  for (std::size_t k = 0; k < y.size(); ++k) {
    const int lo = std::max(0, static_cast<int>(std::floor((y[k] - r[k]) / strip)));
    const int hi = std::min(n_strips - 1, static_cast<int>(std::floor((y[k] + r[k]) / strip)));
    for (int s = lo; s <= hi; ++s)
      area[static_cast<std::size_t>(s)] += disk_strip_area(y[k], r[k], s * strip, (s + 1) * strip);
  }
  for (auto& a : area) a /= width * strip;
  return area;
}

double band_volume_fraction(const std::vector<double>& y, const std::vector<double>& r,
                            double width, double a, double b) {
  if (!(b > a)) return std::numeric_limits<double>::quiet_NaN();
  double area = 0.0;
  for (std::size_t k = 0; k < y.size(); ++k) area += disk_strip_area(y[k], r[k], a, b);
  return area / (width * (b - a));
}

double deposit_top(const std::vector<double>& y, const std::vector<double>& r) {
  double top = 0.0;
  for (std::size_t k = 0; k < y.size(); ++k) top = std::max(top, y[k] + r[k]);
  return top;
}

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

Scalar mean_sem(const std::vector<double>& v) {
  Scalar s;
  double sum = 0.0, sum2 = 0.0;
  for (double x : v) {
    if (std::isnan(x)) continue;
    sum += x;
    sum2 += x * x;
    ++s.n;
  }
  if (s.n == 0) {
    s.mean = s.sem = kNaN;
    return s;
  }
  s.mean = sum / s.n;
  const double var = s.n > 1 ? std::max(0.0, (sum2 - s.n * s.mean * s.mean) / (s.n - 1)) : kNaN;
  s.sem = std::sqrt(var / s.n);
  return s;
}

EnsembleProfile ensemble(const std::vector<std::vector<double>>& rows,
                         const std::vector<double>& centre) {
  EnsembleProfile e;
  e.centre = centre;
  for (std::size_t k = 0; k < centre.size(); ++k) {
    std::vector<double> col;
    for (const auto& r : rows) col.push_back(k < r.size() ? r[k] : kNaN);
    const Scalar s = mean_sem(col);
    e.mean.push_back(s.mean);
    e.sem.push_back(s.sem);
    e.members.push_back(s.n);
    e.rel_fluctuation.push_back(s.n > 1 && s.mean != 0.0 ? s.sem * std::sqrt(double(s.n)) / s.mean
                                                         : kNaN);
  }
  return e;
}

namespace {

// Standard error of a pooled mean sum_j s_j / sum_j c_j over members j (sums s_j of c_j samples
// each): the delete-one-member jackknife of the ratio, the members being the independent units.
// Where every member has the same count it is the standard error of the members' own means; a
// member without samples in the bin counts as one of the ensemble's members. NaN unless two
// members or more have samples (leaving out the only one leaves no mean).
double pooled_mean_sem(const std::vector<double>& sums, const std::vector<double>& counts) {
  const std::size_t n = sums.size();
  double total = 0.0, samples = 0.0;
  for (std::size_t j = 0; j < n; ++j) {
    total += sums[j];
    samples += counts[j];
  }
  std::vector<double> without(n);
  double mean_without = 0.0;
  for (std::size_t j = 0; j < n; ++j) {
    if (!(samples - counts[j] > 0.0)) return kNaN;
    without[j] = (total - sums[j]) / (samples - counts[j]);
    mean_without += without[j] / static_cast<double>(n);
  }
  if (n < 2) return kNaN;
  double sum2 = 0.0;
  for (double w : without) sum2 += (w - mean_without) * (w - mean_without);
  return std::sqrt(sum2 * static_cast<double>(n - 1) / static_cast<double>(n));
}

// Avalanche profile: Delta y binned by `key` (y_i or y_e), pooled over the members that did not
// fail, with the jackknife standard error of the pooled bin mean over those members, and one
// row per member (failed ones included, empty) of the per-member bin statistics.
BinnedStat binned(const std::vector<const MemberResult*>& members, bool by_initial, double bin,
                  int n_bins) {
  BinnedStat b;
  const auto N = static_cast<std::size_t>(n_bins);
  std::vector<double> sum(N, 0.0), sum2(N, 0.0), cnt(N, 0.0), keys(N, 0.0);
  // Per bin, each member's summed Delta y and samples (the members that did not fail).
  std::vector<std::vector<double>> member_sums(N), member_counts(N);
  for (const auto* r : members) {
    std::vector<double> ms(N, 0.0), mk(N, 0.0), mc(N, 0.0);
    for (std::size_t k = 0; r->ok() && k < r->y_e.size(); ++k) {
      const double key = by_initial ? r->y_i[k] : r->y_e[k];
      const int j = static_cast<int>(std::floor(key / bin));
      if (j < 0 || j >= n_bins) continue;
      const double dy = r->y_e[k] - r->y_i[k];
      const auto u = static_cast<std::size_t>(j);
      sum[u] += dy;
      sum2[u] += dy * dy;
      keys[u] += key;
      cnt[u] += 1.0;
      ms[u] += dy;
      mk[u] += key;
      mc[u] += 1.0;
    }
    for (std::size_t u = 0; r->ok() && u < N; ++u) {
      member_sums[u].push_back(ms[u]);
      member_counts[u].push_back(mc[u]);
    }
    for (std::size_t u = 0; u < N; ++u) {
      ms[u] = mc[u] > 0.0 ? ms[u] / mc[u] : kNaN;
      mk[u] = mc[u] > 0.0 ? mk[u] / mc[u] : kNaN;
    }
    b.member_mean.push_back(std::move(ms));
    b.member_position.push_back(std::move(mk));
    b.member_count.push_back(std::move(mc));
  }
  for (std::size_t u = 0; u < N; ++u) {
    b.centre.push_back((static_cast<double>(u) + 0.5) * bin);
    b.count.push_back(cnt[u]);
    b.position.push_back(cnt[u] > 0.0 ? keys[u] / cnt[u] : kNaN);
    if (cnt[u] == 0.0) {
      b.mean.push_back(kNaN);
      b.stddev.push_back(kNaN);
      b.sem.push_back(kNaN);
      continue;
    }
    const double m = sum[u] / cnt[u];
    b.mean.push_back(m);
    b.stddev.push_back(cnt[u] > 1.0
                           ? std::sqrt(std::max(0.0, (sum2[u] - cnt[u] * m * m) / (cnt[u] - 1.0)))
                           : kNaN);
    b.sem.push_back(pooled_mean_sem(member_sums[u], member_counts[u]));
  }
  return b;
}

// The per-member rows of one point, and the members' samples its ensemble means are taken over.
struct MemberSamples {
  std::vector<const MemberResult*> all, ok;  // every member of the point; those that did not fail
  std::vector<std::vector<double>> nu_rows, nud_rows;
  std::vector<double> lower_half, abs_dy_means, nu_i, rel;  // nu_i and rel: protocol C
};

// Adds member r of point pt to pr's per-member rows and to the samples (failed members only to
// the rows, with NaN where a value needs a valid deposit).
void add_member(const ScanPoint& pt, const ObservableSettings& obs, int n_strips,
                const MemberResult& r, PointResult& pr, MemberSamples& m) {
  const SystemParams& p = pt.params;
  const double H = p.height;
  const double lower_half_from = obs.lower_half_from_at(H);
  ++pr.members;
  m.all.push_back(&r);
  const double top = deposit_top(r.y_e, r.radius);
  pr.m_disks.push_back(static_cast<double>(r.y_e.size()));
  pr.m_top.push_back(top);
  pr.m_steps.push_back(static_cast<double>(r.steps));
  pr.m_sweeps.push_back(static_cast<double>(r.sweeps));
  pr.m_wall_time.push_back(r.wall_time);
  pr.m_failure.push_back(static_cast<double>(r.failure));
  pr.m_capped.push_back(r.capped);
  pr.m_seed_index.push_back(r.member.seed_index);
  // For C the final deposit is lower than H: its bulk band ends at half its own top.
  const double band_top = pt.protocol == Protocol::C ? 0.5 * top : 0.5 * H;
  const double nlh = band_volume_fraction(r.y_e, r.radius, p.width, lower_half_from, band_top);
  pr.m_nu_lower_half.push_back(r.ok() ? nlh : kNaN);
  if (!r.ok()) {
    ++pr.failed;
    pr.m_mean_abs_dy.push_back(kNaN);
    if (pt.protocol == Protocol::C) pr.m_nu_initial.push_back(kNaN);
    pr.nu_member_rows.emplace_back(static_cast<std::size_t>(n_strips), kNaN);
    pr.nu_deposition_member_rows.emplace_back(static_cast<std::size_t>(n_strips), kNaN);
    return;  // failed members are excluded from every aggregate
  }
  m.ok.push_back(&r);
  m.nu_rows.push_back(volume_fraction_profile(r.y_e, r.radius, p.width, obs.strip_width, n_strips));
  pr.nu_member_rows.push_back(m.nu_rows.back());
  // Deposition density: disk area by deposition height y_i (centre counting of y_i).
  std::vector<double> nud(static_cast<std::size_t>(n_strips), 0.0);
  double sum_abs = 0.0;
  for (std::size_t k = 0; k < r.y_i.size(); ++k) {
    const int s = static_cast<int>(std::floor(r.y_i[k] / obs.strip_width));
    if (s >= 0 && s < n_strips)
      nud[static_cast<std::size_t>(s)] +=
          M_PI * r.radius[k] * r.radius[k] / (p.width * obs.strip_width);
    sum_abs += std::fabs(r.y_e[k] - r.y_i[k]);
  }
  m.nud_rows.push_back(nud);
  pr.nu_deposition_member_rows.push_back(nud);
  m.lower_half.push_back(nlh);
  m.abs_dy_means.push_back(r.y_i.empty() ? kNaN : sum_abs / static_cast<double>(r.y_i.size()));
  pr.m_mean_abs_dy.push_back(m.abs_dy_means.back());
  if (pt.protocol == Protocol::C) {
    // nu_i only where dnu/nu_i is defined (the final band not empty), so that nu_initial, nu_final
    // and dnu/nu_i are means over the same members, as the fit of dnu/nu_i against nu_i pairs them.
    const double ni = std::isfinite(nlh)
                          ? band_volume_fraction(r.y_i, r.radius, p.width, lower_half_from,
                                                 0.5 * deposit_top(r.y_i, r.radius))
                          : kNaN;
    m.nu_i.push_back(ni);
    m.rel.push_back((nlh - ni) / ni);
    pr.m_nu_initial.push_back(ni);
  }
}

// |Delta y| histograms of point pt: all disks, and without the bottom and top of the final
// deposit; summed and per member.
void add_abs_dy_histograms(const ScanPoint& pt, const ObservableSettings& obs,
                           const MemberSamples& m, PointResult& pr) {
  const double H = pt.params.height;
  const double cut_bottom = obs.cut_bottom_at(H), cut_top = obs.cut_top_at(H);
  double max_abs = 0.0;
  for (const auto* r : m.ok)
    for (std::size_t k = 0; k < r->y_i.size(); ++k)
      max_abs = std::max(max_abs, std::fabs(r->y_e[k] - r->y_i[k]));
  // Bounded by the box (a member whose disk left it has failed, Failure::Escaped), so the bin
  // count stays small and within int whatever a member reports.
  max_abs = std::min(max_abs, escape_height(pt.params));
  const int n_hist = std::max(1, static_cast<int>(std::floor(max_abs / obs.abs_dy_bin)) + 1);
  for (int k = 0; k <= n_hist; ++k) pr.abs_dy_edges.push_back(k * obs.abs_dy_bin);
  pr.abs_dy_counts.assign(static_cast<std::size_t>(n_hist), 0.0);
  pr.abs_dy_counts_cut.assign(static_cast<std::size_t>(n_hist), 0.0);
  for (const auto* r : m.all) {
    std::vector<double> counts(static_cast<std::size_t>(n_hist), 0.0), cut = counts;
    const double top = r->ok() ? deposit_top(r->y_e, r->radius) : 0.0;
    for (std::size_t k = 0; r->ok() && k < r->y_i.size(); ++k) {
      const double a = std::fabs(r->y_e[k] - r->y_i[k]);
      const auto j = static_cast<std::size_t>(
          std::min(n_hist - 1, static_cast<int>(std::floor(a / obs.abs_dy_bin))));
      counts[j] += 1.0;
      if (r->y_e[k] >= cut_bottom && r->y_e[k] <= top - cut_top) cut[j] += 1.0;
    }
    for (std::size_t j = 0; j < counts.size(); ++j) {
      pr.abs_dy_counts[j] += counts[j];
      pr.abs_dy_counts_cut[j] += cut[j];
    }
    pr.abs_dy_member_counts.push_back(std::move(counts));
    pr.abs_dy_member_counts_cut.push_back(std::move(cut));
  }
}

// Avalanche events (protocol A): logarithmic bins, 4 per decade from 1e-3 to 1e5, of the disks
// an event moved, how far down and how many steps it took; summed and per member.
void add_event_histograms(const MemberSamples& m, PointResult& pr) {
  const int per_decade = 4, decades = 8;
  for (int k = 0; k <= per_decade * decades; ++k)
    pr.event_edges.push_back(std::pow(10.0, -3.0 + static_cast<double>(k) / per_decade));
  const auto nb = static_cast<std::size_t>(per_decade * decades);
  pr.event_downward_counts.assign(nb, 0.0);
  pr.event_moved_counts.assign(nb, 0.0);
  pr.event_steps_counts.assign(nb, 0.0);
  auto bin_of = [&](double v) {
    const int j = static_cast<int>(std::floor((std::log10(v) + 3.0) * per_decade));
    return static_cast<std::size_t>(std::clamp(j, 0, per_decade * decades - 1));
  };
  for (const auto* r : m.all) {
    std::vector<double> downward(nb, 0.0), moved(nb, 0.0), steps(nb, 0.0);
    for (std::size_t k = 0; r->ok() && k < r->events.size(); ++k) {
      const AvalancheEvent& ev = r->events[k];
      if (ev.steps > 0) steps[bin_of(static_cast<double>(ev.steps))] += 1.0;
      if (ev.moved == 0) {
        pr.events_without_motion += 1.0;
        continue;
      }
      moved[bin_of(ev.moved)] += 1.0;
      if (ev.downward > 0.0) downward[bin_of(ev.downward)] += 1.0;
    }
    for (std::size_t j = 0; j < nb; ++j) {
      pr.event_downward_counts[j] += downward[j];
      pr.event_moved_counts[j] += moved[j];
      pr.event_steps_counts[j] += steps[j];
    }
    pr.event_member_downward_counts.push_back(std::move(downward));
    pr.event_member_moved_counts.push_back(std::move(moved));
    pr.event_member_steps_counts.push_back(std::move(steps));
  }
}

// The ensemble of point pt over its members in results.
PointResult point_result(const ScanPoint& pt, const ObservableSettings& obs,
                         const std::vector<MemberResult>& results) {
  PointResult pr;
  pr.point = pt;
  const double H = pt.params.height;
  // The strips that fit below H: a last strip over H would count empty space above every disk.
  const int n_strips = std::max(1, static_cast<int>(std::floor(H / obs.strip_width)));
  const int n_bins = std::max(1, static_cast<int>(std::ceil(H / obs.bin_width)));
  MemberSamples m;
  for (const auto& r : results)
    if (r.member.point == pt.index) add_member(pt, obs, n_strips, r, pr, m);
  std::vector<double> strip_centre;
  for (int s = 0; s < n_strips; ++s) strip_centre.push_back((s + 0.5) * obs.strip_width);
  pr.nu = ensemble(m.nu_rows, strip_centre);
  pr.nu_deposition = ensemble(m.nud_rows, strip_centre);
  pr.nu_lower_half = mean_sem(m.lower_half);
  pr.mean_abs_dy = mean_sem(m.abs_dy_means);
  pr.nu_initial = mean_sem(m.nu_i);
  // C's final density is its lower-half density (the band ends at half the final top).
  pr.nu_final = pt.protocol == Protocol::C ? pr.nu_lower_half : mean_sem({});
  pr.relative_increase = mean_sem(m.rel);
  pr.dy_by_yi = binned(m.all, true, obs.bin_width, n_bins);
  pr.dy_by_ye = binned(m.all, false, obs.bin_width, n_bins);
  add_abs_dy_histograms(pt, obs, m, pr);
  if (pt.protocol == Protocol::A) add_event_histograms(m, pr);
  return pr;
}

}  // namespace

std::vector<PointResult> aggregate(const Scan& scan, const std::vector<MemberResult>& results) {
  std::vector<PointResult> out;
  for (const auto& pt : scan.points) out.push_back(point_result(pt, scan.observables, results));
  return out;
}

}  // namespace loosepack
