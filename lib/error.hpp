// Typed errors: the CLI maps each to a one-line message and a non-zero exit.
#pragma once
#include <stdexcept>
#include <string>

namespace jamflow {

// Bad scene, option or input file: names the key, the value and what is allowed.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The dynamics left the physical domain (non-finite values, negative volume, ...).
class IntegrationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Reading or writing a file failed.
class IoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// An input the user named (scene, init configuration) cannot be opened or read: bad input,
// like a ConfigError (exit status 2), where a failed output is an IoError (exit status 1).
class InputFileError : public IoError {
 public:
  using IoError::IoError;
};

}  // namespace jamflow
