// Scene validation: unknown, missing and out-of-range keys give one-line errors that name the
// key, the value and what is allowed.
#include <gtest/gtest.h>

#include <functional>

#include "lib/config.hpp"
#include "lib/error.hpp"

namespace jamflow {
namespace {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(Config, NumberChecksTypeAndRange) {
  Scene s = Scene::parse("[system]\nphi = 1.2\nN = \"many\"\n", "t.toml");
  ConfigSection sys = s.section("system");
  const std::string e = error_of([&] { sys.number("phi", Range{0.0, 0.95, true, false}); });
  EXPECT_NE(e.find("[system] phi = 1.2"), std::string::npos) << e;
  EXPECT_NE(e.find("(0, 0.95]"), std::string::npos) << e;
  const std::string e2 = error_of([&] { sys.integer("N", 2, 1000); });
  EXPECT_NE(e2.find("[system] N = \"many\" is not an integer"), std::string::npos) << e2;
}

TEST(Config, MissingAndUnknownKeys) {
  Scene s = Scene::parse("[run]\nt_eq = 1.0\nt_avv = 2.0\n", "t.toml");
  ConfigSection run = s.section("run");
  EXPECT_DOUBLE_EQ(run.number("t_eq", Range::non_negative()), 1.0);
  const std::string missing = error_of([&] { run.number("t_av", Range::positive()); });
  EXPECT_NE(missing.find("missing key [run] t_av"), std::string::npos) << missing;
  const std::string unknown = error_of([&] { run.finish(); });
  EXPECT_NE(unknown.find("unknown key [run] t_avv = 2"), std::string::npos) << unknown;
}

TEST(Config, ChoiceListsAllowedValues) {
  Scene s = Scene::parse("[integrator]\nkind = \"rk4\"\n", "t.toml");
  ConfigSection sec = s.section("integrator");
  const std::string e = error_of([&] { sec.choice("kind", {"euler", "respa"}); });
  EXPECT_NE(e.find("[integrator] kind = \"rk4\" is not allowed; allowed \"euler\", \"respa\""),
            std::string::npos)
      << e;
}

TEST(Config, OverridesAreTypedAndCreateSections) {
  Scene s = Scene::parse("[shear]\nrate = 1e-3\n", "t.toml");
  s.set("shear.rate=2e-4");
  s.set("output.file=run.h5");  // bare word: a string
  ConfigSection sh = s.section("shear");
  EXPECT_DOUBLE_EQ(sh.number("rate", Range::positive()), 2e-4);
  ConfigSection out = s.section("output");
  EXPECT_EQ(out.text("file", ""), "run.h5");
  EXPECT_NE(s.text().find("rate = 0.0002"), std::string::npos) << s.text();
  EXPECT_THROW(s.set("noequals"), ConfigError);
  EXPECT_THROW(s.set("nodot=3"), ConfigError);
}

TEST(Config, SyntaxErrorNamesTheLine) {
  const std::string e = error_of([] { Scene::parse("[system]\nN = = 3\n", "bad.toml"); });
  EXPECT_NE(e.find("bad.toml:2"), std::string::npos) << e;
}

TEST(Config, UnknownSection) {
  Scene s = Scene::parse("[sytem]\nN = 3\n", "t.toml");
  const std::string e = error_of([&] { s.check_sections({"system"}); });
  EXPECT_NE(e.find("unknown section [sytem]"), std::string::npos) << e;
}

}  // namespace
}  // namespace jamflow
