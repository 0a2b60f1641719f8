// Typed integrator settings: the driver runs exactly the values it is handed, the TOML path
// converts a scene's [integrator] section into the same settings, and the stored scene text
// describes the run exactly.
#include <gtest/gtest.h>

#include <string>

#include "driver/run.hpp"
#include "lib/error.hpp"

namespace jamflow {
namespace {

const char* const kScene =
    "[system]\nN = 100\nphi = 0.6\nseed = 3\n[ensemble]\nkind = \"constant_volume\"\n"
    "[shear]\nrate = 1e-3\n[run]\nt_eq = 0.0\nt_av = 10.0\nsample_every = 0.5\nthreads = 1\n";

TEST(TypedSettings, DriverUsesTheExactDoubleAndTheSceneTextRoundTrips) {
  const double dt = 0.1 / 3.0;  // 0.033333333333333333 (17 digits), not 0.0333333
  const IntegratorSettings settings = IntegratorSettings("euler").set("dt", dt);
  const RunSpec spec = parse_run_spec(Scene::parse(kScene, "typed.toml"), settings);
  EXPECT_EQ(spec.integrator, settings);
  EXPECT_EQ(spec.integrator.number("dt"), dt);
  EXPECT_EQ(spec.make_integrator()->nominal_dt(), dt);

  // The stored scene parses back to the same settings, bit for bit, through the TOML path.
  const Scene stored = Scene::parse(spec.scene_text, "stored");
  ConfigSection sec = stored.section("integrator");
  EXPECT_EQ(sec.number("dt", Range::positive()), dt);
  const RunSpec again = parse_run_spec(stored);
  EXPECT_EQ(again.integrator, settings);
  EXPECT_EQ(again.scene_text, spec.scene_text);
}

TEST(TypedSettings, TomlPathGivesTheSameSettings) {
  const std::string text = std::string(kScene) +
                           "[integrator]\nkind = \"respa\"\ndt = 0.25\nn_inner = 3\n"
                           "inner = \"piston\"\n";
  const RunSpec spec = parse_run_spec(Scene::parse(text, "toml.toml"));
  const IntegratorSettings expected =
      IntegratorSettings("respa").set("dt", 0.25).set("n_inner", 3).set("inner", "piston");
  EXPECT_EQ(spec.integrator, expected);
  EXPECT_EQ(spec.make_integrator()->name(), "respa");
}

TEST(TypedSettings, ValidatedLikeAScene) {
  const Scene scene = Scene::parse(kScene, "typed.toml");
  auto error_of = [&](const IntegratorSettings& s) -> std::string {
    try {
      parse_run_spec(scene, s);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_NE(error_of(IntegratorSettings("euler").set("dt", -1.0)).find("[integrator] dt = -1"),
            std::string::npos);
  EXPECT_NE(error_of(IntegratorSettings("euler").set("dt", 0.1).set("n_inner", 4))
                .find("unknown key [integrator] n_inner"),
            std::string::npos);
  EXPECT_NE(error_of(IntegratorSettings("rk4")).find("allowed \"cvode\", \"euler\", \"respa\""),
            std::string::npos);
  // The scene's own [integrator] and typed settings at once: two sources for one setting.
  Scene both = scene;
  both.set("integrator.kind=\"euler\"");
  EXPECT_THROW(parse_run_spec(both, IntegratorSettings("euler").set("dt", 0.1)), ConfigError);
}

}  // namespace
}  // namespace jamflow
