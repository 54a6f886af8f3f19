// Keeps one frame source alive: opens it through a factory, and when it fails (SourceError,
// a factory error) or ends, closes it, logs once per change of state, and reopens it with
// exponential back-off. The camera thread just calls read() in its loop.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "ips/capture/frame_source.h"

namespace ips {

struct BackoffOptions {
  double initial_s = 0.5;  ///< first wait before reopening, seconds
  double max_s = 10.0;     ///< the wait doubles after each failed attempt up to this, seconds
};

/// Creates a fresh, unopened source (called for every (re)open attempt). May throw.
using SourceFactory = std::function<std::unique_ptr<FrameSource>()>;

class SourceSupervisor {
 public:
  enum class State { kClosed, kOpen, kBackoff };

  /// Injectable time for tests: `now` returns CLOCK_MONOTONIC-like ns; `sleep` waits (a test
  /// advances its fake clock instead).
  struct Clock {
    std::function<std::int64_t()> now;
    std::function<void(std::chrono::nanoseconds)> sleep;
  };
  static Clock system_clock();

  SourceSupervisor(std::string name, SourceFactory factory, BackoffOptions backoff = {}, Clock clock = system_clock());
  ~SourceSupervisor();

  /// One open attempt now (start-up). Returns true if open; else the supervisor is in back-off
  /// and last_error() says why.
  bool open();

  /// Next frame: kFrame (out filled), kCorrupt (counted; the source stays open), or kTimeout
  /// (nothing within `timeout`, or the source is down and waiting to be reopened: the call then
  /// sleeps at most `timeout`, so the caller's loop stays responsive). Never throws for source
  /// failures and never returns kEnd: an ended source is reopened like a failed one.
  FrameSource::ReadStatus read(Frame& out, std::chrono::milliseconds timeout);

  /// Asks every source it opens from now on to hand JPEG frames over undecoded
  /// (FrameSource::defer_decode; the camera thread decodes only what its tracker needs).
  /// read() clears Frame::jpeg first, so a frame from a source that decodes never carries a
  /// stale JPEG.
  void set_defer_decode(bool on);

  State state() const { return state_; }
  const std::string& last_error() const { return last_error_; }
  std::string describe() const { return description_; }
  std::uint64_t failures() const { return failures_; }  ///< failed opens + run-time failures + ends
  std::uint64_t opens() const { return opens_; }        ///< successful opens
  double current_backoff_s() const { return backoff_s_; }

 private:
  void fail(const std::string& why);

  std::string name_;
  SourceFactory factory_;
  BackoffOptions options_;
  Clock clock_;
  std::unique_ptr<FrameSource> source_;
  State state_ = State::kClosed;
  std::string description_;
  std::string last_error_;
  std::string last_logged_;
  double backoff_s_;
  std::int64_t retry_at_ns_ = 0;
  bool delivered_since_open_ = false;
  std::uint64_t failures_ = 0;
  std::uint64_t opens_ = 0;
  bool defer_decode_ = false;
};

}  // namespace ips
