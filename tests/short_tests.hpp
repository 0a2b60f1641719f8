// Heavy tests run shorter under a sanitizer (scripts/sanitize.sh): AddressSanitizer and
// UndefinedBehaviorSanitizer make the code several times slower, and the whole suite must still
// run there, not be excluded. A shortened test checks the same things on a shorter run.
//
// Short when the tests are built with -DJAMFLOW_SANITIZE=ON (JAMFLOW_SHORT_TESTS is defined) or
// when the environment variable JAMFLOW_SHORT_TESTS is set to anything but "0" (the shell-script
// tests read it too). A shortened test prints "[shortened]" with its name, which
// scripts/sanitize.sh counts.
#pragma once
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>

namespace jamflow::testing_support {

inline bool short_tests() {
#ifdef JAMFLOW_SHORT_TESTS
  return true;
#else
  const char* e = std::getenv("JAMFLOW_SHORT_TESTS");
  return e && *e && std::string(e) != "0";
#endif
}

// `full`, or `shorter` in a short test run (and says so).
template <class T>
T shortened(T full, T shorter) {
  if (!short_tests())
    return full;
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::printf("[shortened] %s.%s\n", info ? info->test_suite_name() : "?",
              info ? info->name() : "?");
  return shorter;
}

}  // namespace jamflow::testing_support
