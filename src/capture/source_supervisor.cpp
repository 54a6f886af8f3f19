#include "ips/capture/source_supervisor.h"

#include <algorithm>
#include <thread>

#include <spdlog/spdlog.h>

#include "ips/core/clock.h"
#include "ips/core/error.h"

namespace ips {

SourceSupervisor::Clock SourceSupervisor::system_clock() {
  return {[] { return monotonic_ns(); }, [](std::chrono::nanoseconds d) { std::this_thread::sleep_for(d); }};
}

SourceSupervisor::SourceSupervisor(std::string name, SourceFactory factory, BackoffOptions backoff, Clock clock)
    : name_(std::move(name)),
      factory_(std::move(factory)),
      options_(backoff),
      clock_(std::move(clock)),
      backoff_s_(backoff.initial_s) {}

SourceSupervisor::~SourceSupervisor() {
  if (source_) source_->close();
}

void SourceSupervisor::fail(const std::string& why) {
  if (source_) {
    source_->close();
    source_.reset();
  }
  ++failures_;
  last_error_ = why;
  retry_at_ns_ = clock_.now() + static_cast<std::int64_t>(backoff_s_ * 1e9);
  // One log line per change of state: the first failure, or a different error than last time.
  if (state_ != State::kBackoff || why != last_logged_) {
    spdlog::warn("{}: {}; retrying every {:.1f} s (up to {:.0f} s) until it works", name_, why, backoff_s_,
                 options_.max_s);
    last_logged_ = why;
  } else {
    spdlog::debug("{}: still failing: {} (next try in {:.1f} s)", name_, why, backoff_s_);
  }
  backoff_s_ = std::min(backoff_s_ * 2.0, options_.max_s);
  delivered_since_open_ = false;
  state_ = State::kBackoff;
}

bool SourceSupervisor::open() {
  try {
    source_ = factory_();
    description_ = source_->describe();
    if (defer_decode_) source_->defer_decode(true);
    source_->open();
  } catch (const std::exception& e) {
    fail(std::string("cannot open ") + (description_.empty() ? "source" : description_) + ": " + e.what());
    return false;
  }
  const bool was_down = state_ == State::kBackoff;
  state_ = State::kOpen;
  ++opens_;
  delivered_since_open_ = false;
  if (was_down) {
    spdlog::info("{}: {} is back (after {} failure(s))", name_, description_, failures_);
  } else {
    spdlog::info("{}: opened {}", name_, description_);
  }
  last_logged_.clear();
  return true;
}

void SourceSupervisor::set_defer_decode(bool on) {
  defer_decode_ = on;
  if (source_) source_->defer_decode(on);
}

FrameSource::ReadStatus SourceSupervisor::read(Frame& out, std::chrono::milliseconds timeout) {
  out.jpeg.clear();  // only a deferring source fills it (keeps its capacity)
  if (state_ != State::kOpen) {
    const std::int64_t now = clock_.now();
    if (state_ == State::kBackoff && now < retry_at_ns_) {
      clock_.sleep(std::chrono::nanoseconds(std::min<std::int64_t>(retry_at_ns_ - now, timeout.count() * 1'000'000)));
      return FrameSource::ReadStatus::kTimeout;
    }
    if (!open()) return FrameSource::ReadStatus::kTimeout;
  }
  FrameSource::ReadStatus status;
  try {
    status = source_->read(out, timeout);
  } catch (const std::exception& e) {
    fail(description_ + " failed: " + e.what());
    return FrameSource::ReadStatus::kTimeout;
  }
  if (status == FrameSource::ReadStatus::kEnd) {
    fail(description_ + " ended");
    return FrameSource::ReadStatus::kTimeout;
  }
  if (status == FrameSource::ReadStatus::kFrame) {
    // The wait grows only while attempts keep failing: a source that delivers again starts
    // from the initial wait at its next failure.
    if (!delivered_since_open_) backoff_s_ = options_.initial_s;
    delivered_since_open_ = true;
  }
  return status;
}

}  // namespace ips
