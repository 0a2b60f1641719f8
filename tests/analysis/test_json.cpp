// JSON writer and parser: round trip, full precision, refusal of non-finite
// numbers.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "analysis/errors.hpp"
#include "analysis/json.hpp"

namespace jamflow::analysis {
namespace {

TEST(Json, RoundTripKeepsOrderAndFullPrecision) {
  Json j = Json::object();
  j["b"] = 0.1 + 0.2;  // not representable in 15 digits
  j["a"] = Json::array();
  j["a"].push_back(1);
  j["a"].push_back("x\"y\n");
  j["n"] = static_cast<std::int64_t>(10000);
  j["flag"] = true;
  j["none"] = Json();
  Json back = Json::parse(j.dump());
  ASSERT_EQ(back.members().size(), 5u);
  EXPECT_EQ(back.members()[0].first, "b");  // insertion order kept
  EXPECT_EQ(back.at("b").as_number(), 0.1 + 0.2);
  EXPECT_EQ(back.at("a").at(1).as_string(), "x\"y\n");
  EXPECT_EQ(back.at("n").as_number(), 10000.0);
  EXPECT_NE(j.dump().find("\"n\": 10000"), std::string::npos);  // integers without exponent
  EXPECT_TRUE(back.at("flag").as_bool());
  EXPECT_EQ(back.at("none").kind(), Json::Kind::kNull);
}

TEST(Json, NonFiniteNumberIsAnErrorNamingItsPath) {
  Json j = Json::object();
  j["sizes"]["1000"]["phi_J"]["error"] = std::numeric_limits<double>::quiet_NaN();
  try {
    (void)j.dump();
    FAIL() << "expected FitError";
  } catch (const FitError& e) {
    EXPECT_NE(std::string(e.what()).find("sizes.1000.phi_J.error"), std::string::npos) << e.what();
  }
  Json k = Json::object();
  k["x"] = std::numeric_limits<double>::infinity();
  EXPECT_THROW((void)k.dump(), FitError);
}

TEST(Json, ParserRejectsMalformedText) {
  EXPECT_THROW(Json::parse("{\"a\": 1,}"), InputError);
  EXPECT_THROW(Json::parse("[1 2]"), InputError);
  EXPECT_THROW(Json::parse("{\"a\": 1} x"), InputError);
  EXPECT_THROW(Json::parse("\"unterminated"), InputError);
}

TEST(Json, KeysAreShortestRoundTripText) {
  EXPECT_EQ(format_key(1e-5), "1e-05");
  EXPECT_EQ(format_key(0.6474), "0.6474");
  EXPECT_EQ(format_key(1e-7 * 3), "3e-07");
  for (double x : {1e-4, 0.1 + 0.2, 3.0e-9, 12345.678}) {
    EXPECT_EQ(std::stod(format_key(x)), x);  // round trip
  }
}

}  // namespace
}  // namespace jamflow::analysis
