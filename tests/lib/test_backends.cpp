// Every force backend, and the simd backend on every Highway target this CPU runs, against the
// reference (all pairs, minimum image, the general pair law even at alpha_r = 2).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <ostream>
#include <string>
#include <vector>

#include "ensembles/constant_volume.hpp"
#include "integrators/euler.hpp"
#include "lib/error.hpp"
#include "lib/forces.hpp"
#include "lib/init.hpp"
#include "lib/kernels/simd.hpp"
#include "lib/model.hpp"

namespace jamflow {
namespace {

struct BackendCase {
  std::string kernel;  // "portable" or "simd"
  std::string target;  // simd: the Highway target it is pinned to
  bool supported = true;
};

void PrintTo(const BackendCase& c, std::ostream* os) {
  *os << c.kernel << (c.target.empty() ? "" : " on " + c.target);
}

std::vector<BackendCase> backend_cases() {
  std::vector<BackendCase> out = {{"portable", "", true}};
  for (const kernels::SimdTarget& t : kernels::simd_targets())
    out.push_back({"simd", t.name, t.supported});
  return out;
}

std::string case_name(const testing::TestParamInfo<BackendCase>& info) {
  std::string s = info.param.kernel + (info.param.target.empty() ? "" : "_" + info.param.target);
  std::replace_if(
      s.begin(), s.end(), [](char c) { return !std::isalnum(c) && c != '_'; }, '_');
  return s;
}

class Backend : public testing::TestWithParam<BackendCase> {
 protected:
  void SetUp() override {
    const BackendCase& c = GetParam();
    if (!c.supported)
      GTEST_SKIP() << "simd target " << c.target << " is compiled but this CPU cannot run it";
    if (!c.target.empty())
      kernels::simd_pin_target(c.target);
  }
  void TearDown() override { kernels::simd_pin_target(""); }
};

// A sheared system through strain 1.6 (two Lees–Edwards remaps), reordered in memory every
// second list build, with its own forces checked against the reference at 16 points on the
// way, on one to three threads (three: a range receives deferred forces from two others) and
// at alpha_r = 1.5, 2, 2.5, 3.
//
// Tolerances: the backends form pair vectors from real-space rows or scaled differences, and
// the simd law takes delta^(alpha - 1) as exp((alpha - 1) log delta) (Highway's Exp and Log, a
// few ulp) where the reference calls std::pow; both are round-off, relative 1e-15 to 1e-14 per
// pair. Forces are checked to 1e-11 of the largest force, energy and virial to 1e-11 relative:
// three orders of magnitude of margin, and far below any error of the physics (a missing
// contact changes the forces at the 1e-3 level).
TEST_P(Backend, MatchesTheReferenceThroughShearRemapsAndReorders) {
  const BackendCase& c = GetParam();
  for (double alpha : {1.5, 2.0, 2.5, 3.0}) {
    for (int threads : {1, 2, 3}) {
      const std::string where =
          "alpha " + std::to_string(alpha) + ", " + std::to_string(threads) + " thread(s)";
      Model m(random_state(300, 0.64, 17), ModelOptions{alpha, 0.3, threads, 2, c.kernel});
      ASSERT_EQ(m.force_field().kernel(), c.kernel) << where;
      if (!c.target.empty()) {
        ASSERT_EQ(m.force_field().target(), c.target) << where;
      }
      ConstantVolume ens(2e-2);
      Euler euler(0.1);
      ForceField reference(alpha, 1, "reference");
      std::size_t checked = 0;
      for (int k = 1; k <= 16; ++k) {
        euler.advance(m, ens, 5.0 * k);
        const Evaluation& ev = m.evaluate();
        ForceResult ref;
        reference.compute(m.state(), m.neighbour_list(), ref);
        ASSERT_GT(ref.contacts, m.state().size()) << where;  // a dense, jammed packing
        ASSERT_EQ(ev.forces.contacts, ref.contacts) << where << ", t " << 5.0 * k;
        double fmax = 0.0, err = 0.0;
        for (std::size_t q = 0; q < ref.force.size(); ++q) {
          fmax = std::max(fmax, std::abs(ref.force[q]));
          err = std::max(err, std::abs(ev.forces.force[q] - ref.force[q]));
        }
        ASSERT_LE(err, 1e-11 * fmax) << where << ", t " << 5.0 * k;
        EXPECT_NEAR(ev.forces.energy, ref.energy, 1e-11 * ref.energy) << where;
        const double scale = ref.virial.cwiseAbs().maxCoeff();
        EXPECT_LT((ev.forces.virial - ref.virial).cwiseAbs().maxCoeff(), 1e-11 * scale) << where;
        const double v = m.state().box.volume();
        EXPECT_NEAR(ev.pressure, ref.virial.trace() / (3.0 * v), 1e-11 * scale / v) << where;
        EXPECT_NEAR(ev.sigma_xy, -ref.virial(0, 1) / v, 1e-11 * scale / v) << where;
        double f2 = 0.0;
        for (double f : ref.force)
          f2 += f * f;
        EXPECT_NEAR(ev.dissipation, f2, 1e-10 * f2) << where;
        ++checked;
      }
      EXPECT_EQ(checked, 16u);
      EXPECT_EQ(m.state().box.flips, 2) << where;  // through two remaps
      EXPECT_GT(m.list_builds(), 4u) << where;     // and so through reorders (every 2 builds)
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AllBackends, Backend, testing::ValuesIn(backend_cases()), case_name);

// The choice of backend: "auto" takes simd wherever this CPU has a vector target for it; names
// outside the list are refused with the allowed ones.
TEST(Backends, AutoPicksSimdWhereAVectorTargetRuns) {
  const ForceField ff(2.0, 1);
  const bool vector = kernels::simd_current_target().vector;
  const char* forced = std::getenv("JAMFLOW_KERNEL");  // a whole test run forced to a backend
  if (forced && *forced)
    EXPECT_EQ(ff.kernel(), forced);
  else
    EXPECT_EQ(ff.kernel(), vector ? "simd" : "portable");
  EXPECT_FALSE(ff.target().empty());
  try {
    ForceField bad(2.0, 1, "avx512");
    FAIL() << "an unknown kernel was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("\"portable\""), std::string::npos) << e.what();
  }
  EXPECT_THROW(kernels::simd_pin_target("NO_SUCH_TARGET"), ConfigError);
}

// The build compiles the simd kernel for targets beyond the baseline, AVX2 and AVX-512 among
// them, whether or not this CPU runs them.
TEST(Backends, SimdIsCompiledForAVX2AndAVX512) {
#if defined(__AVX2__)
  GTEST_SKIP() << "built with -march (JAMFLOW_NATIVE=ON): Highway compiles only the targets at "
                  "and above the build machine's";
#endif
  bool avx2 = false, avx3 = false;
  std::string names;
  for (const kernels::SimdTarget& t : kernels::simd_targets()) {
    avx2 = avx2 || t.name == "AVX2";
    avx3 = avx3 || t.name == "AVX3";
    names += t.name + (t.supported ? " " : " (not on this CPU) ");
  }
  EXPECT_TRUE(avx2) << names;
  EXPECT_TRUE(avx3) << names;
  std::printf("compiled simd targets: %s\n", names.c_str());
}

}  // namespace
}  // namespace jamflow
