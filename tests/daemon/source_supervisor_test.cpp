#include "ips/capture/source_supervisor.h"

#include <deque>

#include <gtest/gtest.h>
#include <spdlog/sinks/ringbuffer_sink.h>
#include <spdlog/spdlog.h>

#include "ips/core/error.h"

namespace ips {
namespace {

// What the fake source does at each call, in order.
enum class Step { kOpenFails, kOpenOk, kFrame, kThrow, kEnd, kCorrupt };

struct Script {
  std::deque<Step> steps;
  int created = 0;
  int closed = 0;
  Step next() {
    if (steps.empty()) return Step::kFrame;
    const Step s = steps.front();
    steps.pop_front();
    return s;
  }
};

class FakeSource : public FrameSource {
 public:
  explicit FakeSource(Script& s) : s_(s) { ++s_.created; }
  void open() override {
    if (s_.next() == Step::kOpenFails) throw SourceError("no such device");
  }
  ReadStatus read(Frame& out, std::chrono::milliseconds) override {
    switch (s_.next()) {
      case Step::kThrow: throw SourceError("unplugged");
      case Step::kEnd: return ReadStatus::kEnd;
      case Step::kCorrupt: return ReadStatus::kCorrupt;
      default: out.sequence = ++frames_; return ReadStatus::kFrame;
    }
  }
  void close() noexcept override { ++s_.closed; }
  std::string describe() const override { return "fake:0"; }

 private:
  Script& s_;
  std::uint64_t frames_ = 0;
};

// A fake clock that only moves when the supervisor sleeps.
struct FakeTime {
  std::int64_t now = 0;
  SourceSupervisor::Clock clock() {
    return {[this] { return now; }, [this](std::chrono::nanoseconds d) { now += d.count(); }};
  }
};

class SupervisorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    sink_ = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(100);
    previous_ = spdlog::default_logger();
    spdlog::set_default_logger(std::make_shared<spdlog::logger>("test", sink_));
  }
  void TearDown() override { spdlog::set_default_logger(previous_); }
  int warnings() {
    int n = 0;
    for (const auto& line : sink_->last_formatted()) n += line.find("[warning]") != std::string::npos;
    return n;
  }
  std::shared_ptr<spdlog::sinks::ringbuffer_sink_mt> sink_;
  std::shared_ptr<spdlog::logger> previous_;
};

TEST_F(SupervisorTest, FailedOpensBackOffDoublingToTheCapAndLogOnce) {
  Script script;
  for (int i = 0; i < 7; ++i) script.steps.push_back(Step::kOpenFails);
  script.steps.push_back(Step::kOpenOk);
  FakeTime t;
  SourceSupervisor sup(
      "cam0", [&] { return std::make_unique<FakeSource>(script); }, {}, t.clock());
  EXPECT_FALSE(sup.open());
  EXPECT_EQ(sup.state(), SourceSupervisor::State::kBackoff);
  EXPECT_NE(sup.last_error().find("no such device"), std::string::npos);

  // Record the fake time of every reopen attempt.
  std::vector<std::int64_t> attempts;
  Frame f;
  int created = script.created;
  while (sup.state() != SourceSupervisor::State::kOpen) {
    const auto status = sup.read(f, std::chrono::milliseconds(100));
    if (script.created != created) {
      attempts.push_back(t.now);
      created = script.created;
    }
    ASSERT_NE(status, FrameSource::ReadStatus::kEnd);
  }
  // Waits: 0.5, 1, 2, 4, 8, 10, 10 s between the 8 attempts.
  const std::vector<std::int64_t> expected = {500'000'000,    1'500'000'000,  3'500'000'000, 7'500'000'000,
                                              15'500'000'000, 25'500'000'000, 35'500'000'000};
  EXPECT_EQ(attempts, expected);
  EXPECT_EQ(sup.failures(), 7u);
  EXPECT_EQ(warnings(), 1);  // the same error repeated is logged once
}

TEST_F(SupervisorTest, ThrowingAndEndingSourcesAreClosedAndReopened) {
  Script script;
  script.steps = {Step::kOpenOk, Step::kFrame, Step::kCorrupt, Step::kThrow,  // run-time failure
                  Step::kOpenOk, Step::kFrame, Step::kEnd,                    // the source ends
                  Step::kOpenOk, Step::kFrame};
  FakeTime t;
  SourceSupervisor sup(
      "cam1", [&] { return std::make_unique<FakeSource>(script); }, {}, t.clock());
  ASSERT_TRUE(sup.open());
  Frame f;
  EXPECT_EQ(sup.read(f, std::chrono::milliseconds(10)), FrameSource::ReadStatus::kFrame);
  EXPECT_EQ(sup.read(f, std::chrono::milliseconds(10)), FrameSource::ReadStatus::kCorrupt);
  EXPECT_EQ(sup.state(), SourceSupervisor::State::kOpen);  // a corrupt frame is no failure
  EXPECT_EQ(sup.read(f, std::chrono::milliseconds(10)), FrameSource::ReadStatus::kTimeout);  // threw
  EXPECT_EQ(sup.state(), SourceSupervisor::State::kBackoff);
  EXPECT_NE(sup.last_error().find("unplugged"), std::string::npos);
  EXPECT_EQ(script.closed, 1);

  int frames = 0;
  for (int i = 0; i < 200 && frames < 2; ++i)
    frames += sup.read(f, std::chrono::milliseconds(100)) == FrameSource::ReadStatus::kFrame;
  EXPECT_EQ(frames, 2);  // reopened after the throw, and again after the end
  EXPECT_EQ(script.created, 3);
  EXPECT_EQ(script.closed, 2);
  EXPECT_EQ(sup.opens(), 3u);
  EXPECT_EQ(sup.failures(), 2u);
  EXPECT_NE(sup.last_error().find("ended"), std::string::npos);
  // The source delivered a frame before each failure, so each wait started over at 0.5 s:
  // total fake time = 0.5 + 0.5.
  EXPECT_EQ(t.now, 1'000'000'000);
  EXPECT_EQ(warnings(), 2);  // two different failures -> two lines
}

TEST_F(SupervisorTest, AFactoryThatThrowsIsAFailedOpen) {
  FakeTime t;
  int calls = 0;
  SourceSupervisor sup(
      "cam2",
      [&]() -> std::unique_ptr<FrameSource> {
        ++calls;
        throw InputError("scene.yaml: no camera 'x'");
      },
      {}, t.clock());
  EXPECT_FALSE(sup.open());
  Frame f;
  for (int i = 0; i < 10; ++i)
    EXPECT_EQ(sup.read(f, std::chrono::milliseconds(100)), FrameSource::ReadStatus::kTimeout);
  EXPECT_EQ(calls, 2);  // 1 s of fake time: the first retry at 0.5 s, the next due at 1.5 s
  EXPECT_NE(sup.last_error().find("no camera 'x'"), std::string::npos);
}

}  // namespace
}  // namespace ips
