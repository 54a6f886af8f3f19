// Error types shared by every stage.
#pragma once

#include <stdexcept>
#include <string>

namespace ips {

/// Bad user input: a data file, a config file, a model file, a command-line value.
/// The message always names the thing and the place ("train.csv:12: column 'zc': ...").
/// Programs print it and exit with status 2; the daemon refuses the input and keeps running.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A frame source failed at run time (camera unplugged, scene ended unexpectedly, ...).
/// The daemon logs it, counts it and reopens the source with back-off.
class SourceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace ips
