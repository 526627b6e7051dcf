// The validation cases of MODEL.md with their exact answers.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "loosepack/batch.hpp"
#include "tests/scenes.hpp"

using namespace loosepack;
using namespace loosepack::scenes;

namespace {
SolverSettings tight(SolverKind kind = SolverKind::GaussSeidel) {
  SolverSettings s;
  s.kind = kind;
  s.tolerance = 1e-10;
  s.max_sweeps = 200000;
  return s;
}
}  // namespace

// 1. Column of N disks: the contact below the k-th disk from the top carries k m g.
TEST(Validation, ColumnCarriesWeights) {
  const int n = 50;
  auto p = bare_params(20.0, 110.0);
  p.friction = 0.3;
  p.rolling_friction = 0.1;
  Batch batch({setup(p, column(n, 10.0))}, tight());
  for (int k = 0; k < 20; ++k) batch.step();
  ASSERT_EQ(batch.status(0).failure, Failure::None);
  EXPECT_TRUE(batch.status(0).converged);
  const double mg = p.reference_mass() * p.gravity;
  int checked = 0;
  for (const auto& c : batch.contacts(0)) {
    const int below = c.j < 0 ? 0 : c.i + 1;  // index of the upper disk of the pair
    const int upper = c.j < 0 ? c.i : c.j;
    (void)below;
    if (c.j >= 0 && c.j != c.i + 1) {
      EXPECT_NEAR(c.normal, 0.0, 1e-9);  // no other contacts should carry force
      continue;
    }
    const int from_top = n - upper;  // disks at and above `upper`
    EXPECT_NEAR(c.normal, from_top * mg, 1e-6 * from_top * mg) << "contact below disk " << upper;
    EXPECT_NEAR(c.tangential, 0.0, 1e-9);
    ++checked;
  }
  EXPECT_EQ(checked, n);
  const auto d = batch.disks(0);
  for (int k = 0; k < n; ++k) {
    EXPECT_NEAR(d[k].x, 10.0, 1e-9);
    EXPECT_NEAR(d[k].y, 1.0 + 2.0 * k, 1e-6);
  }
  std::printf("column of %d: %ld sweeps over 20 steps (first step %ld)\n", n,
              batch.status(0).sweeps, batch.status(0).sweeps);
}
