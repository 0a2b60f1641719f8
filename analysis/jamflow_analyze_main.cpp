// Stand-alone `jamflow-analyze` executable: the same as `jamflow analyze`.
#include <string>
#include <vector>

#include "analysis/analyze_cli.hpp"

int main(int argc, char** argv) {
  return jamflow::analysis::analyze_main(std::vector<std::string>(argv + 1, argv + argc));
}
