// Writes example CSV tables from the paper's formulas (tests/analysis/
// synthetic.hpp), to try `jamflow analyze` end to end:
//   make_synthetic_data OUTDIR  ->  OUTDIR/granular.csv, two_branch.csv, soft_flow.csv
#include <cstdio>
#include <fstream>
#include <iostream>
#include <string>

#include "tests/analysis/synthetic.hpp"

using namespace jamflow::analysis;
using namespace jamflow::analysis::testing;

namespace {

std::string num(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.10g", x);
  return buf;
}

void write_granular(const std::string& path, const std::vector<GranularPoint>& pts) {
  std::ofstream out(path);
  out << "# synthetic: Table 2 + soft granular rheology (x = 0.75, y = 0.56)\n";
  out << "N,imposed_pressure,shear_rate,phi,phi_err,mu,mu_err\n";
  for (const auto& p : pts) {
    out << p.n << "," << num(p.pressure) << "," << num(p.shear_rate) << "," << num(p.phi) << ","
        << num(p.phi_err) << "," << num(p.mu) << "," << num(p.mu_err) << "\n";
  }
}

void write_shear(const std::string& path, const std::vector<ShearPoint>& pts) {
  std::ofstream out(path);
  out << "N,phi,shear_rate,sigma_xy,sigma_xy_err\n";
  for (const auto& p : pts) {
    out << p.n << "," << num(p.phi) << "," << num(p.shear_rate) << "," << num(p.sigma) << ","
        << num(p.sigma_err) << "\n";
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: make_synthetic_data OUTDIR\n";
    return 2;
  }
  const std::string dir = argv[1];
  GranularSpec g;
  g.sizes = {100, 300, 500, 1000, 3000, 10000};
  write_granular(dir + "/granular.csv", make_granular(g));
  TwoBranchSpec t;
  write_shear(dir + "/two_branch.csv", make_two_branch(t));
  write_shear(dir + "/soft_flow.csv", make_soft_flow_curves(t, SoftTruth{}));
  return 0;
}
