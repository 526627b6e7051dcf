// Where a disk dropped onto the deposit still lands below the box height H (protocol A's
// `protocol.stop_rule = "no_room"`, docs/MODEL.md "Protocols"). A disk of radius r dropped at x
// (DropRule::Touch, kernels/deposit.hpp) lands with its centre at the highest y_j +
// sqrt((r + r_j)^2 - dx^2) over the disks within reach, or at r on the floor. It stays below H
// where that centre is at most H - r, so every disk j blocks the open interval of x where
// y_j + sqrt((r + r_j)^2 - dx^2) > H - r: all |dx| < r + r_j when y_j > H - r, else
// |dx| < sqrt((r + r_j)^2 - (H - r - y_j)^2). The free abscissae are the periodic width less
// the union of those intervals.
#pragma once
#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>
#include <vector>

#include "loosepack/batch.hpp"

namespace loosepack {

// Gaps narrower than this many radii count as no room: a drop there would land at H to
// rounding, and a random abscissa would almost never find them.
constexpr double kNarrowestRoom = 1e-6;

// The free abscissae of a deposit of periodic width `width` for a disk of radius r, as disjoint
// intervals [a, b) in [0, width), each wider than kNarrowestRoom r. A margin of 1e-9 r below
// H keeps a drop inside them below H after rounding.
inline std::vector<std::pair<double, double>> room_below(const std::vector<Disk>& disks,
                                                         double width, double height, double r) {
  const double limit = height - r - 1e-9 * r;  // the highest centre allowed
  if (limit < r) return {};                    // not even the floor has room
  std::vector<std::pair<double, double>> blocked;
  for (const Disk& d : disks) {
    const double reach = r + d.radius;
    const double below = limit - d.y;
    if (below >= reach) continue;
    const double half = below < 0.0 ? reach : std::sqrt(reach * reach - below * below);
    if (2.0 * half >= width) return {};
    const double a = d.x - half - width * std::floor((d.x - half) / width);
    const double b = a + 2.0 * half;
    if (b <= width) {
      blocked.emplace_back(a, b);
    } else {  // across the seam
      blocked.emplace_back(a, width);
      blocked.emplace_back(0.0, b - width);
    }
  }
  std::sort(blocked.begin(), blocked.end());
  std::vector<std::pair<double, double>> free;
  double from = 0.0;  // the end of the blocked union so far
  const auto keep = [&](double a, double b) {
    if (b - a > kNarrowestRoom * r) free.emplace_back(a, b);
  };
  for (const auto& [a, b] : blocked) {
    if (a > from) keep(from, a);
    from = std::max(from, b);
  }
  keep(from, width);
  return free;
}

// The abscissa at fraction u in [0, 1) of the free intervals' total width (a uniform draw
// among them for a uniform u); none where there is no room.
inline std::optional<double> free_abscissa(const std::vector<std::pair<double, double>>& free,
                                           double u) {
  double total = 0.0;
  for (const auto& [a, b] : free) total += b - a;
  if (total <= 0.0) return std::nullopt;
  double at = u * total;
  for (const auto& [a, b] : free) {
    if (at < b - a) return a + at;
    at -= b - a;
  }
  return free.back().second - 0.5 * (free.back().second - free.back().first);
}

}  // namespace loosepack
