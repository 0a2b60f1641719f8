// The P* rule of the softness study (analysis/p_star.hpp) on synthetic pressure scans against a
// common reference: the chain of agreeing points from the smallest pressure up, the flags at its
// ends, the points left out below it, and no comparison without a usable reference.
#include <gtest/gtest.h>

#include <cmath>

#include "analysis/p_star.hpp"

using namespace jamflow::analysis;

namespace {
ScanValue sv(double p, double mu, double phi, bool usable = true) {
  return {p, usable, mu, 0.005, phi, 0.001};
}
}  // namespace

TEST(PStar, AgainstTheCommonReference) {
  const ScanValue ref = sv(0.0, 0.40, 0.578);
  // Listed in any order: 1e-3 and 3e-3 agree, 1e-2 differs in phi by 10 sigma.
  const PStar a =
      find_p_star({sv(1e-2, 0.40, 0.592), sv(1e-3, 0.401, 0.5785), sv(3e-3, 0.399, 0.5795)}, ref);
  EXPECT_TRUE(a.reached);
  EXPECT_DOUBLE_EQ(a.p_star, 3e-3);
  EXPECT_FALSE(a.p_star_is_smallest);
  EXPECT_FALSE(a.p_star_is_largest);
  EXPECT_EQ(a.smallest, 1);
  EXPECT_EQ(a.agrees, (std::vector<int>{0, 1, 1}));
  // The smallest P differs: the scan never reached the limit, whatever larger P does.
  const PStar b = find_p_star({sv(3e-3, 0.40, 0.578), sv(1e-3, 0.40, 0.590)}, ref);
  EXPECT_FALSE(b.reached);
  EXPECT_TRUE(std::isnan(b.p_star));
  EXPECT_EQ(b.left_out_below, 0);
  // ... unless a smaller P was left out by its verdicts (here one that agrees): then "not
  // reached" is not established.
  const PStar f = find_p_star(
      {sv(3e-3, 0.40, 0.578), sv(1e-3, 0.40, 0.590), sv(1e-4, 0.401, 0.578, false)}, ref);
  EXPECT_FALSE(f.reached);
  EXPECT_EQ(f.left_out_below, 1);
  EXPECT_TRUE(f.left_out_below_agrees);
  const PStar g = find_p_star(
      {sv(3e-3, 0.40, 0.578), sv(1e-3, 0.40, 0.590), sv(1e-4, 0.40, 0.600, false)}, ref);
  EXPECT_EQ(g.left_out_below, 1);
  EXPECT_FALSE(g.left_out_below_agrees);
  // An unusable point is not compared, and does not break the chain.
  const PStar c =
      find_p_star({sv(1e-4, 0.2, 0.7, false), sv(1e-3, 0.40, 0.578), sv(1e-2, 0.30, 0.578)}, ref);
  EXPECT_EQ(c.agrees[0], -1);
  EXPECT_EQ(c.smallest, 1);
  EXPECT_DOUBLE_EQ(c.p_star, 1e-3);
  EXPECT_TRUE(c.p_star_is_smallest);  // mu differs at 1e-2 (14 sigma)
  // Every usable point agrees: P* is the largest, a lower bound.
  const PStar e = find_p_star({sv(1e-3, 0.40, 0.578), sv(3e-3, 0.40, 0.579)}, ref);
  EXPECT_DOUBLE_EQ(e.p_star, 3e-3);
  EXPECT_TRUE(e.p_star_is_largest);
  EXPECT_FALSE(e.p_star_is_smallest);
  // No usable reference: nothing is compared.
  const PStar d = find_p_star({sv(1e-3, 0.40, 0.578)}, sv(0.0, 0.4, 0.578, false));
  EXPECT_EQ(d.smallest, -1);
  EXPECT_TRUE(std::isnan(d.p_star));
}
