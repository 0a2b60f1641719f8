// Scene validation: unknown, missing and out-of-range keys give one-line errors that name the
// key, the value and what is allowed.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <random>

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

// toml++ 3.3 reaches undefined behaviour classifying most non-ASCII characters as whitespace
// or not (found by fuzz_scene): they are refused where TOML allows only ASCII.
TEST(Config, NonAsciiOutsideStringsIsRefusedBeforeTheParser) {
  EXPECT_EQ(error_of([] { Scene::parse("[system]\nN = 1\xCF\x87\n", "t.toml"); }),
            "t.toml:2: non-ASCII character outside a string or comment; allowed: ASCII there "
            "(keys, numbers, booleans, dates and escapes); any text inside quoted strings and "
            "comments");
  const std::string after_backslash =
      error_of([] { Scene::parse("x = 1\ns = \"\"\"\\\n\xC2\xA7\"\"\"\n", "t.toml"); });
  EXPECT_NE(after_backslash.find("t.toml:3: non-ASCII character right after a backslash"),
            std::string::npos)
      << after_backslash;
  // A quote in the middle of a value does not start a string (the parser scans on).
  EXPECT_NE(error_of([] {
              Scene::parse("x = +'\xC3\x84'\n", "t.toml");
            }).find("t.toml:1: non-ASCII character outside a string or comment"),
            std::string::npos);
  EXPECT_NE(error_of([] {
              Scene::parse("N=[[[3+=[['[P\xEF\xBB\xBDP\n", "t.toml");
            }).find("t.toml:1: non-ASCII character outside a string or comment"),
            std::string::npos);
  const std::string escape = error_of([] { Scene::parse("s = \"a\\\xC2\xA7\"\n", "t.toml"); });
  EXPECT_NE(escape.find("t.toml:1: non-ASCII character right after a backslash"), std::string::npos)
      << escape;

  // Text in comments and strings of every kind stays allowed, and quotes inside strings do
  // not end them early.
  const Scene ok = Scene::parse(
      "\xEF\xBB\xBF# Kolb\xE2\x80\x93"
      "D\xC3\xBCnweg piston\n[output]\n"
      "file = \"r\xC3\xA9sum\xC3\xA9 \\\" # \xC3\xBC.h5\" # \xC2\xA7\n"
      "a = '\xC2\xA7'\nb = \"\"\"\n\xC2\xA7 \"\" \xC2\xA7\"\"\"\"\nc = '''\xC2\xA7'''\n",
      "t.toml");
  ConfigSection out = ok.section("output");
  EXPECT_EQ(out.text("file", ""), "r\xC3\xA9sum\xC3\xA9 \" # \xC3\xBC.h5");
  EXPECT_EQ(out.text("a", ""), "\xC2\xA7");
  EXPECT_EQ(out.text("b", ""), "\xC2\xA7 \"\" \xC2\xA7\"");
  EXPECT_EQ(out.text("c", ""), "\xC2\xA7");
  const Scene arrays = Scene::parse(
      "[t]\nd = [[\"\xC2\xA7\", 1], [{k = '\xC2\xA7', \"\xC2\xA7\" = 2}], 3]\n[[u]]\n\"\xC2\xA7\" "
      "= 1\n",
      "t.toml");
  EXPECT_NE(arrays.table("t"), nullptr);

  // An override that is not TOML because of such a character is taken as a string.
  Scene s = Scene::parse("[output]\n", "t.toml");
  s.set("output.file=\xC3\xBC.h5");
  EXPECT_EQ(s.section("output").text("file", ""), "\xC3\xBC.h5");
}

TEST(Config, UnknownSection) {
  Scene s = Scene::parse("[sytem]\nN = 3\n", "t.toml");
  const std::string e = error_of([&] { s.check_sections({"system"}); });
  EXPECT_NE(e.find("unknown section [sytem]"), std::string::npos) << e;
}

// Scenes print every float in its shortest form that reads back to the same double (toml++ as
// Debian builds it printed 17 digits: dt = 0.10000000000000001), and keep toml++'s layout.
TEST(Config, FloatsPrintShortestAndReadBackExactly) {
  const Scene s = Scene::parse(
      "[integrator]\ndt = 0.1\n[system]\nphi = 0.5686\nN = 32\n[shear]\nrate = 3e-3\n"
      "[run]\nt_av = 30000.0\nt_eq = 0.0\n[sweep.grid]\n\"shear.rate\" = [1e-5, 0.3, 2.0]\n"
      "[x]\nname = \"0.10000000000000001\"\ntable = { a = 0.7, b = [[0.25]] }\n",
      "t.toml");
  const std::string text = s.text();
  for (const char* want : {"dt = 0.1\n", "phi = 0.5686\n", "N = 32\n", "rate = 0.003\n",
                           "t_av = 30000.0\n", "t_eq = 0.0\n", "[ 1e-05, 0.3, 2.0 ]",
                           "name = '0.10000000000000001'", "a = 0.7", "[ [ 0.25 ] ]"})
    EXPECT_NE(text.find(want), std::string::npos) << want << " in\n" << text;
  std::string floats_only = text;
  floats_only.erase(text.find("name = "),
                    text.find('\n', text.find("name = ")) - text.find("name = "));
  EXPECT_EQ(floats_only.find("0000000"), std::string::npos) << text;
  // The same tables as toml++ lays them out: only the floats differ.
  const std::string legacy = s.legacy_text();
  EXPECT_NE(legacy.find("dt = 0.10000000000000001\n"), std::string::npos) << legacy;
  EXPECT_EQ(Scene::parse(text, "t").legacy_text(), legacy);
  EXPECT_EQ(canonical_scene_text(legacy), text);
  EXPECT_EQ(canonical_scene_text("[x\n"), "");
  // toml++ prints a table's values before its sub-tables, whatever their keys' order.
  const Scene nested = Scene::parse("[run]\nz = 0.5\n[run.a]\nq = 0.25\n", "n.toml");
  EXPECT_EQ(nested.text(), "[run]\nz = 0.5\n\n    [run.a]\n    q = 0.25\n") << nested.text();
}

TEST(Config, ShortestFloatsRoundTripBitForBit) {
  std::mt19937_64 rng(7);
  std::vector<double> values = {0.0,
                                -0.0,
                                1.0,
                                -3.0,
                                1e22,
                                1e-5,
                                0.1,
                                1.0 / 3.0,
                                std::numeric_limits<double>::max(),
                                std::numeric_limits<double>::min(),
                                std::numeric_limits<double>::denorm_min(),
                                std::numeric_limits<double>::infinity(),
                                -std::numeric_limits<double>::infinity()};
  for (int k = 0; k < 2000; ++k) {
    double v = std::bit_cast<double>(rng());
    if (std::isfinite(v))
      values.push_back(v);
  }
  toml::table t;
  toml::array a;
  for (std::size_t k = 0; k < values.size(); ++k) {
    t.insert(std::string("v").append(std::to_string(k)), values[k]);
    a.push_back(values[k]);
  }
  t.insert("all", std::move(a));
  const toml::table back = toml::parse(toml_text(t));
  for (std::size_t k = 0; k < values.size(); ++k) {
    const auto* v = back.get(std::string("v").append(std::to_string(k)));
    ASSERT_TRUE(v && v->is_floating_point()) << values[k];
    EXPECT_EQ(std::bit_cast<std::uint64_t>(v->as_floating_point()->get()),
              std::bit_cast<std::uint64_t>(values[k]))
        << toml_float(values[k]);
    EXPECT_EQ(std::bit_cast<std::uint64_t>(back["all"][k].value<double>().value()),
              std::bit_cast<std::uint64_t>(values[k]));
  }
  EXPECT_EQ(toml_float(std::nan("")), "nan");
  // Written as Python's repr writes floats.
  EXPECT_EQ(toml_float(2e-4), "0.0002");
  EXPECT_EQ(toml_float(1e-5), "1e-05");
  EXPECT_EQ(toml_float(30000.0), "30000.0");
  EXPECT_EQ(toml_float(1e16), "1e+16");
  EXPECT_EQ(toml_float(0.56859999999999999), "0.5686");
  // A string that looks like the printer's marker is kept as it is.
  toml::table odd{{"s", "@jamflow-float-0@"}, {"x", 0.1}};
  EXPECT_EQ(toml::parse(toml_text(odd))["s"].value<std::string>(), "@jamflow-float-0@");
  EXPECT_EQ(toml::parse(toml_text(odd))["x"].value<double>(), 0.1);
}

}  // namespace
}  // namespace jamflow
