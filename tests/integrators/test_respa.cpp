// RESPA: scene keys, the declared order of every configuration, the analytic two-sphere
// relaxation and its measured convergence order. The dense-system order and the ensemble
// contract are in test_contract.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "ensembles/constant_pressure.hpp"
#include "ensembles/constant_volume.hpp"
#include "integrators/respa.hpp"
#include "lib/error.hpp"
#include "lib/model.hpp"
#include "tests/two_spheres.hpp"

namespace jamflow {
namespace {

std::unique_ptr<Integrator> from_toml(const std::string& body) {
  const Scene scene = Scene::parse("[integrator]\n" + body, "respa-test.toml");
  ConfigSection sec = scene.section("integrator");
  return make_integrator(sec);
}

std::string error_of(const std::string& body) {
  try {
    from_toml(body);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(Respa, SceneKeysAndDefaults) {
  auto integ = from_toml("kind = \"respa\"\ndt = 0.5\n");
  auto* r = dynamic_cast<Respa*>(integ.get());
  ASSERT_NE(r, nullptr);
  EXPECT_EQ(r->name(), "respa");
  EXPECT_DOUBLE_EQ(r->nominal_dt(), 0.5);
  EXPECT_EQ(r->options().n_inner, 4);
  EXPECT_EQ(r->options().inner, RespaOptions::Level::kParticles);
  EXPECT_EQ(r->options().inner_scheme, RespaOptions::Scheme::kEuler);
  EXPECT_EQ(r->options().outer_scheme, RespaOptions::Scheme::kEuler);
  // outer_scheme follows inner_scheme unless given.
  auto h = from_toml(
      "kind = \"respa\"\ndt = 1\nn_inner = 2\ninner = \"piston\"\n"
      "inner_scheme = \"heun\"\n");
  r = dynamic_cast<Respa*>(h.get());
  ASSERT_NE(r, nullptr);
  EXPECT_EQ(r->options().n_inner, 2);
  EXPECT_EQ(r->options().inner, RespaOptions::Level::kPiston);
  EXPECT_EQ(r->options().outer_scheme, RespaOptions::Scheme::kHeun);
}

TEST(Respa, BadKeysNameKeyValueAndRange) {
  EXPECT_NE(error_of("kind = \"respa\"\n").find("[integrator] dt"), std::string::npos);
  const std::string n0 = error_of("kind = \"respa\"\ndt = 1\nn_inner = 0\n");
  EXPECT_NE(n0.find("[integrator] n_inner = 0"), std::string::npos) << n0;
  EXPECT_NE(n0.find("[1, 100000]"), std::string::npos) << n0;
  const std::string frac = error_of("kind = \"respa\"\ndt = 1\nn_inner = 2.5\n");
  EXPECT_NE(frac.find("n_inner"), std::string::npos) << frac;
  const std::string lvl = error_of("kind = \"respa\"\ndt = 1\ninner = \"cell\"\n");
  EXPECT_NE(lvl.find("[integrator] inner = \"cell\""), std::string::npos) << lvl;
  EXPECT_NE(lvl.find("piston"), std::string::npos) << lvl;
  const std::string sch = error_of("kind = \"respa\"\ndt = 1\ninner_scheme = \"rk4\"\n");
  EXPECT_NE(sch.find("inner_scheme = \"rk4\""), std::string::npos) << sch;
  EXPECT_NE(sch.find("heun"), std::string::npos) << sch;
  const std::string neg = error_of("kind = \"respa\"\ndt = -1\n");
  EXPECT_NE(neg.find("[integrator] dt = -1"), std::string::npos) << neg;
  // RESPA reads only its own keys: a key of another kind is an unknown key.
  const std::string other = error_of("kind = \"respa\"\ndt = 1\nrtol = 1e-6\n");
  EXPECT_NE(other.find("unknown key [integrator] rtol"), std::string::npos) << other;
}

TEST(Respa, DeclaredOrderPerConfiguration) {
  const ConstantVolume nv(1e-3);
  const ConstantPressure np(1e-3, 1e-3, 1e-4);
  struct Case {
    const char* keys;
    int with_piston, nv_order;
  };
  const Case cases[] = {
      {"", 1, 1},
      {"inner_scheme = \"heun\"", 2, 2},
      {"inner_scheme = \"heun\"\nouter_scheme = \"euler\"", 1, 2},  // NV: outer level exact
      {"inner_scheme = \"euler\"\nouter_scheme = \"heun\"", 1, 1},
      {"inner = \"piston\"", 1, 1},
      {"inner = \"piston\"\ninner_scheme = \"heun\"", 2, 2},
      {"inner = \"piston\"\ninner_scheme = \"heun\"\nouter_scheme = \"euler\"", 1, 1},
      {"inner = \"piston\"\nouter_scheme = \"heun\"", 1, 2},  // NV: the particles are outer
  };
  for (const auto& c : cases) {
    auto integ = from_toml(std::string("kind = \"respa\"\ndt = 1\n") + c.keys + "\n");
    const auto* r = dynamic_cast<const Respa*>(integ.get());
    ASSERT_NE(r, nullptr);
    EXPECT_EQ(r->order(), c.with_piston) << c.keys;
    EXPECT_EQ(r->order(np), c.with_piston) << c.keys;
    EXPECT_EQ(r->order(nv), c.nv_order) << c.keys;
  }
}

using fixtures::two_spheres;  // tests/two_spheres.hpp

double overlap_after(const RespaOptions& o, double t_end) {
  Model m(two_spheres(0.8), ModelOptions{2.0, 0.3, 1, 0});
  ConstantVolume ens(1e-2);  // same y: the shear must not change the relaxation
  Respa respa(o);
  respa.advance(m, ens, t_end);
  EXPECT_DOUBLE_EQ(m.state().time, t_end);
  const Eigen::Vector3d d = m.state().real(1) - m.state().real(0);
  return 1.0 - d.norm();
}

struct TwoSphereCase {
  RespaOptions::Level inner;
  RespaOptions::Scheme scheme;
  int n_inner;
  // Leading error of the particle flow on x' = -2x: Euler with sub-step h has global error
  // 2 h t x(t) / 1 (relative 2 h per unit time, since (1 - 2h)^(1/h) = e^-2 (1 - 2h + ...)), Heun
  // relative (4/3) h^2 per unit time. h is the particle sub-step: dt / n_inner when the particles
  // are inner, dt / 2 when they are outer.
  double particle_step(double dt) const {
    return inner == RespaOptions::Level::kParticles ? dt / n_inner : 0.5 * dt;
  }
};

void PrintTo(const TwoSphereCase& c, std::ostream* os) {
  *os << "inner " << (c.inner == RespaOptions::Level::kParticles ? "particles" : "piston") << ", "
      << (c.scheme == RespaOptions::Scheme::kHeun ? "heun" : "euler") << ", n_inner " << c.n_inner;
}

class RespaTwoSpheres : public ::testing::TestWithParam<TwoSphereCase> {};

TEST_P(RespaTwoSpheres, RelaxAsExpMinus2tWithDeclaredOrder) {
  const TwoSphereCase c = GetParam();
  RespaOptions o;
  o.inner = c.inner;
  o.inner_scheme = o.outer_scheme = c.scheme;
  o.n_inner = c.n_inner;
  const double exact = 0.2 * std::exp(-2.0);
  const int p = c.scheme == RespaOptions::Scheme::kHeun ? 2 : 1;
  std::vector<double> err;
  for (double dt : {0.04, 0.02, 0.01, 0.005}) {
    o.dt = dt;
    const double got = overlap_after(o, 1.0);
    const double h = c.particle_step(dt);
    // The leading term predicts the error to O(h^(p+1)); 20% slack on the prediction.
    const double predicted = p == 1 ? 2.0 * h : 4.0 / 3.0 * h * h;
    EXPECT_NEAR(std::abs(got - exact) / exact, predicted, 0.2 * predicted) << "dt " << dt;
    err.push_back(std::abs(got - exact));
  }
  for (std::size_t k = 1; k < err.size(); ++k)
    EXPECT_NEAR(std::log2(err[k - 1] / err[k]), double(p), 0.1) << "refinement " << k;
}

INSTANTIATE_TEST_SUITE_P(
    Configurations, RespaTwoSpheres,
    ::testing::Values(
        TwoSphereCase{RespaOptions::Level::kParticles, RespaOptions::Scheme::kEuler, 4},
        TwoSphereCase{RespaOptions::Level::kParticles, RespaOptions::Scheme::kHeun, 3},
        TwoSphereCase{RespaOptions::Level::kPiston, RespaOptions::Scheme::kEuler, 4},
        TwoSphereCase{RespaOptions::Level::kPiston, RespaOptions::Scheme::kHeun, 2}));

TEST(Respa, LandsExactlyOnRequestedTimeAndCountsSteps) {
  Model m(two_spheres(0.9), ModelOptions{2.0, 0.3, 1, 0});
  ConstantVolume ens(1e-3);
  RespaOptions o;
  o.dt = 0.3;
  o.n_inner = 3;
  Respa respa(o);
  respa.advance(m, ens, 1.0);  // 3 steps of 0.3 and one of 0.1
  EXPECT_DOUBLE_EQ(m.state().time, 1.0);
  EXPECT_NEAR(m.state().box.strain, 1e-3, 1e-15);
  const auto stats = respa.statistics();
  ASSERT_EQ(stats.size(), 2u);
  EXPECT_EQ(stats[0].first, "steps");
  EXPECT_DOUBLE_EQ(stats[0].second, 4.0);
  EXPECT_EQ(stats[1].first, "inner_steps");
  EXPECT_DOUBLE_EQ(stats[1].second, 12.0);
  // Constant volume: the collective level needs no force evaluation, so 3 per outer step.
  EXPECT_EQ(m.force_evaluations(), 12u);
}

}  // namespace
}  // namespace jamflow
