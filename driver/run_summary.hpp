// The summary of a finished run file as the analyses read it: the root attributes and the
// /summary group (README "Output"), read with the HDF5 C API. With driver/checkpoint.hpp and
// driver/run_file.cpp, the run-file module: nothing else opens run files.
#pragma once
#include <cstdint>
#include <string>

namespace jamflow {

struct RunFileSummary {
  std::string path;
  std::string scene, version, git_commit, created;
  std::string ensemble;  // "constant_volume" or "constant_pressure"
  std::int64_t n = 0;
  double sigma_xy = 0, sigma_xy_err = 0, pressure = 0, pressure_err = 0;
  double phi = 0, phi_err = 0, eta = 0, eta_err = 0, mu = 0, mu_err = 0;
  double j = 0, energy_balance = 0, shear_rate = 0, alpha = 0;
  // Several replicas: their count and the replica-scatter errors (NaN when absent; the *_err
  // above are then the block errors of the mean over replicas).
  double replicas = 1;
  double sigma_xy_replica_err = 0, pressure_replica_err = 0, phi_replica_err = 0,
         mu_replica_err = 0;
  bool has_imposed_pressure = false;
  double imposed_pressure = 0;
};

// Reads it in this process. An InputFileError names the file and the missing or mistyped
// attribute. libhdf5 itself can crash on a corrupt file: analysis::read_run_summary calls this
// in a child process.
RunFileSummary read_run_file_summary(const std::string& path);

}  // namespace jamflow
