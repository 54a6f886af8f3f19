// The frame scheduler of the daemon's workers, on a clock the test sets: oldest capture first,
// one frame of a camera at a time, the newest frame of a camera only, the budget, buffer reuse.
#include "ips/capture/frame_scheduler.h"

#include <atomic>
#include <chrono>
#include <thread>

#include <gtest/gtest.h>

namespace ips {
namespace {

constexpr std::int64_t kMs = 1'000'000;
constexpr std::chrono::milliseconds kNoWait{0};

Frame frame_at(std::int64_t capture_ms, std::int64_t delivered_ms, std::uint64_t sequence = 0) {
  Frame f;
  f.sequence = sequence;
  f.t_mono_ns = capture_ms * kMs;
  f.t_delivered_ns = delivered_ms * kMs;
  return f;
}

struct Fixture {
  std::int64_t now_ns = 0;
  FrameScheduler scheduler{{33 * kMs, 33 * kMs, 33 * kMs}, [this] { return now_ns; }};
};

TEST(FrameScheduler, TakesTheOldestCaptureFirstWhateverTheOrderOfArrival) {
  Fixture f;
  f.now_ns = 20 * kMs;
  f.scheduler.submit(2, frame_at(10, 15));
  f.scheduler.submit(0, frame_at(5, 18));  // arrived later, captured earlier
  f.scheduler.submit(1, frame_at(12, 19));
  int camera = -1;
  Frame frame;
  std::vector<int> order;
  while (f.scheduler.take(camera, frame, kNoWait)) {
    order.push_back(camera);
    f.scheduler.done(camera, std::move(frame));
  }
  EXPECT_EQ(order, (std::vector<int>{0, 2, 1}));
  for (int c = 0; c < 3; ++c) EXPECT_EQ(f.scheduler.counters(c).taken, 1u);
}

TEST(FrameScheduler, OneFrameOfACameraAtATime) {
  Fixture f;
  f.now_ns = 10 * kMs;
  f.scheduler.submit(0, frame_at(1, 2));
  int camera = -1;
  Frame a, b;
  ASSERT_TRUE(f.scheduler.take(camera, a, kNoWait));
  EXPECT_EQ(camera, 0);
  f.scheduler.submit(0, frame_at(3, 4));  // camera 0's next frame: waits for the first to finish
  f.scheduler.submit(1, frame_at(5, 6));  // another camera's: free to go
  ASSERT_TRUE(f.scheduler.take(camera, b, kNoWait));
  EXPECT_EQ(camera, 1);
  EXPECT_FALSE(f.scheduler.take(camera, b, kNoWait));  // camera 0 busy, nothing else waits
  f.scheduler.done(0, std::move(a));
  ASSERT_TRUE(f.scheduler.take(camera, a, kNoWait));
  EXPECT_EQ(camera, 0);
  EXPECT_EQ(a.t_mono_ns, 3 * kMs);
}

TEST(FrameScheduler, ANewerFrameReplacesTheOneStillWaiting) {
  Fixture f;
  f.now_ns = 10 * kMs;
  bool superseded = true;
  f.scheduler.submit(0, frame_at(1, 2, 1), &superseded);
  EXPECT_FALSE(superseded);
  f.scheduler.submit(0, frame_at(4, 5, 2), &superseded);
  EXPECT_TRUE(superseded);
  int camera = -1;
  Frame frame;
  ASSERT_TRUE(f.scheduler.take(camera, frame, kNoWait));
  EXPECT_EQ(frame.sequence, 2u);
  EXPECT_EQ(f.scheduler.counters(0).superseded, 1u);
  EXPECT_FALSE(f.scheduler.take(camera, frame, kNoWait));
}

TEST(FrameScheduler, AFrameThatWaitedItsWholeBudgetIsDroppedUnprocessed) {
  Fixture f;
  f.scheduler.submit(0, frame_at(0, 10));
  f.scheduler.submit(1, frame_at(5, 12));
  f.now_ns = 43 * kMs;  // camera 0's frame: 33 ms after delivery, still within; camera 1's too
  int camera = -1;
  Frame frame;
  ASSERT_TRUE(f.scheduler.take(camera, frame, kNoWait));
  EXPECT_EQ(camera, 0);
  f.now_ns = 46 * kMs;  // camera 1's frame waited 34 ms > 33 ms
  EXPECT_FALSE(f.scheduler.take(camera, frame, kNoWait));
  EXPECT_EQ(f.scheduler.counters(1).over_budget, 1u);
  EXPECT_EQ(f.scheduler.counters(1).taken, 0u);
  EXPECT_EQ(f.scheduler.counters(0).wait_ns, 33 * kMs);
}

TEST(FrameScheduler, SpentFramesComeBackToTheirCameraWithTheirBuffers) {
  Fixture f;
  Frame first = frame_at(1, 1);
  first.jpeg.resize(300'000);
  const std::uint8_t* buffer = first.jpeg.data();
  Frame back = f.scheduler.submit(0, std::move(first));
  EXPECT_EQ(back.jpeg.capacity(), 0u);  // nothing spent yet
  int camera = -1;
  Frame frame;
  ASSERT_TRUE(f.scheduler.take(camera, frame, kNoWait));
  f.scheduler.done(camera, std::move(frame));
  back = f.scheduler.submit(1, frame_at(2, 2));  // another camera gets none of camera 0's
  EXPECT_EQ(back.jpeg.capacity(), 0u);
  back = f.scheduler.submit(0, frame_at(3, 3));
  EXPECT_EQ(back.jpeg.data(), buffer);
  EXPECT_GE(back.jpeg.capacity(), 300'000u);
}

TEST(FrameScheduler, CloseWakesAWaitingWorker) {
  FrameScheduler scheduler({33 * kMs});
  std::atomic<bool> returned{false};
  std::thread worker([&] {
    int camera = -1;
    Frame frame;
    EXPECT_FALSE(scheduler.take(camera, frame, std::chrono::seconds(30)));
    returned = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  scheduler.close();
  worker.join();
  EXPECT_TRUE(returned);
}

}  // namespace
}  // namespace ips
