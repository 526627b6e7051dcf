// Observables of one member and their aggregates over the members of a scan point.
#pragma once
#include <string>
#include <vector>

#include "loosepack/protocols.hpp"

namespace loosepack {

// Volume fraction of disks (centres y, radii r) in strips [k w, (k+1) w), k < n_strips.
std::vector<double> volume_fraction_profile(const std::vector<double>& y,
                                            const std::vector<double>& r, double width,
                                            double strip, int n_strips);
// Mean volume fraction of the band [a, b) (exact disk/strip areas).
double band_volume_fraction(const std::vector<double>& y, const std::vector<double>& r,
                            double width, double a, double b);
// Top of a deposit: max(y + r), 0 when empty.
double deposit_top(const std::vector<double>& y, const std::vector<double>& r);

// Mean, standard error (across members) and count of a binned quantity.
struct BinnedStat {
  std::vector<double> centre;
  std::vector<double> position;  // mean key (y_i or y_e) of the samples in the bin: fits use it
  std::vector<double> mean;      // pooled over all samples of all members
  std::vector<double> stddev;    // pooled standard deviation of the samples
  std::vector<double> count;     // samples
  // Standard error of `mean` over members: the delete-one-member jackknife of the pooled ratio
  // (NaN unless two members have samples).
  std::vector<double> sem;
  // The same per member: one row per member of the point, in the order of members/seed_index (a
  // failed member's row has count 0 and NaN means), one entry per bin. The fits' jackknife errors
  // leave one row out at a time. Empty in a file of an older program.
  std::vector<std::vector<double>> member_position, member_mean, member_count;
};

// Mean and standard error over members of a per-member profile (NaN entries skipped).
struct EnsembleProfile {
  std::vector<double> centre, mean, sem, members;
  std::vector<double> rel_fluctuation;  // standard deviation / mean across members
};

struct Scalar {
  double mean = 0.0, sem = 0.0;
  int n = 0;
};

// Mean and standard error of the mean of the values that are not NaN (n of them; NaN mean and
// error when there are none, NaN error when there is one).
Scalar mean_sem(const std::vector<double>& v);

// Columns of per-member profiles (a failed member's row NaN): mean, standard error, members and
// relative fluctuation per entry (mean_sem of each column).
EnsembleProfile ensemble(const std::vector<std::vector<double>>& rows,
                         const std::vector<double>& centre);

struct PointResult {
  ScanPoint point;
  int members = 0, failed = 0;
  EnsembleProfile nu;             // nu(y), strips of strip_width from the floor up to H
  // nu(y) of each member, one row per member in member order (a failed member's row NaN).
  std::vector<std::vector<double>> nu_member_rows;
  std::vector<std::vector<double>> nu_deposition_member_rows;  // the same for nu_d(y_i)
  EnsembleProfile nu_deposition;  // nu_d(y_i): deposited disk area per strip by y_i
  Scalar nu_lower_half;
  BinnedStat dy_by_yi, dy_by_ye;  // avalanche profiles: Delta y = y_e - y_i
  std::vector<double> abs_dy_edges, abs_dy_counts, abs_dy_counts_cut;
  // The same counts per member, one row per member in member order (a failed member's row 0):
  // the histogram fits' errors come from the members' scatter.
  std::vector<std::vector<double>> abs_dy_member_counts, abs_dy_member_counts_cut;
  Scalar mean_abs_dy;
  // Protocol C: bulk volume fraction before (nu_i) and after (nu_f), relative increase.
  Scalar nu_initial, nu_final, relative_increase;
  // Protocol A: avalanche-event size distributions on logarithmic bins.
  std::vector<double> event_edges, event_downward_counts, event_moved_counts;
  std::vector<double> event_steps_counts;  // all events by the steps they took to rest
  // The same per member, one row per member in member order (a failed member's row 0): errors
  // of event statistics from the members' scatter (an avalanche's events are not independent).
  std::vector<std::vector<double>> event_member_downward_counts, event_member_moved_counts,
      event_member_steps_counts;
  double events_without_motion = 0.0;
  // Per member scalars (member order).
  std::vector<double> m_disks, m_top, m_nu_lower_half, m_mean_abs_dy, m_steps, m_sweeps,
      m_wall_time, m_failure, m_capped, m_seed_index;
  // Protocol C: each member's nu_i (NaN where it failed, or where dnu/nu_i is not defined);
  // empty for A and B.
  std::vector<double> m_nu_initial;
};

std::vector<PointResult> aggregate(const Scan& scan, const std::vector<MemberResult>& results);

}  // namespace loosepack
