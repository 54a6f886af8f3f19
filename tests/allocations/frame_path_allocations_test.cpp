// The steady-state frame path allocates no image-sized buffer: a camera's frames, read from a
// preloaded replay source that hands JPEGs over undecoded (as the daemon's cameras do), decoded
// in their ROIs, tracked, and searched whole every `full_search_period` frames (after their
// markers went out, as CameraWorker::process does), reuse the buffers of the frames before them.
//
// This binary replaces glibc's malloc family (glibc supports that: "Replacing malloc" in its
// manual) with a counting shim over glibc's own allocator, so every allocation of the process
// is seen: operator new, OpenCV's fastMalloc (posix_memalign), libjpeg's pools (malloc).
// Only allocations made by the thread under test while it counts are recorded. Under the
// sanitizers (which own malloc themselves) the shim is not built and the test is skipped.
#include <execinfo.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include <gtest/gtest.h>

#include "../detect/moving_markers.h"
#include "ips/capture/file_source.h"
#include "ips/core/image_buffer_pool.h"
#include "ips/detect/tracked_frame_detector.h"

#if defined(__SANITIZE_ADDRESS__)
#define IPS_MALLOC_SHIM 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define IPS_MALLOC_SHIM 0
#endif
#endif
#ifndef IPS_MALLOC_SHIM
#define IPS_MALLOC_SHIM 1
#endif

namespace {

// "Image-sized": a 1920x1080 frame's grey image is 2 MiB, a tracked marker's ROI ~40-200 KiB,
// a JPEG frame ~150-400 KiB. The frame path's small bookkeeping (detections, contours of a
// few points) stays far below this.
constexpr std::size_t kImageSized = 32 * 1024;

struct Recorded {
  std::size_t size;
  void* stack[12];
  int depth;
};
constexpr int kMaxRecorded = 256;

thread_local bool t_counting = false;
thread_local bool t_inside = false;  // backtrace() may allocate: never record from inside
std::atomic<int> g_large{0};
Recorded g_recorded[kMaxRecorded];

[[maybe_unused]] void record(std::size_t size) {
  if (!t_counting || t_inside || size < kImageSized) return;
  t_inside = true;
  const int k = g_large.fetch_add(1);
  if (k < kMaxRecorded) {
    g_recorded[k].size = size;
    g_recorded[k].depth = backtrace(g_recorded[k].stack, 12);
  }
  t_inside = false;
}

}  // namespace

#if IPS_MALLOC_SHIM
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void __libc_free(void*);

void* malloc(std::size_t size) {
  record(size);
  return __libc_malloc(size);
}
void* calloc(std::size_t n, std::size_t size) {
  record(n * size);
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t size) {
  record(size);
  return __libc_realloc(p, size);
}
void free(void* p) { __libc_free(p); }
void* memalign(std::size_t alignment, std::size_t size) {
  record(size);
  return __libc_memalign(alignment, size);
}
void* aligned_alloc(std::size_t alignment, std::size_t size) {
  record(size);
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t size) {
  record(size);
  void* p = __libc_memalign(alignment, size);
  if (p == nullptr) return ENOMEM;
  *out = p;
  return 0;
}
}
#endif

namespace {

using namespace ips_test;  // NOLINT: the helpers of moving_markers.h
namespace fs = std::filesystem;

struct Counting {
  Counting() {
    g_large = 0;
    t_counting = true;
  }
  ~Counting() { t_counting = false; }
};

// What the counted allocations were: OpenCV's contour search (cv::findContours, inside
// cv::aruco::detectMarkers) allocates its own storage on every call: fixed 64 KiB blocks and
// the list of the contours it found (24 bytes per contour, ~125 KiB for a whole-frame search).
// Those are not image buffers and nothing outside OpenCV can hand them a buffer; they are
// counted apart. Everything else is listed with its stack.
struct Tally {
  int contour_storage = 0;
  std::size_t largest_contour_storage = 0;
  std::string others;
};

void tally_recorded(int frame, Tally& tally) {
  const int n = std::min<int>(g_large, kMaxRecorded);
  for (int k = 0; k < n; ++k) {
    char** names = backtrace_symbols(g_recorded[k].stack, g_recorded[k].depth);
    std::string stack;
    bool in_contours = false;
    for (int i = 1; names != nullptr && i < g_recorded[k].depth; ++i) {
      const std::string name = names[i];
      // The frames between the shim and the first caller inside cv::findContours (mangled).
      if (name.find("_ZN2cv12findContours") != std::string::npos) in_contours = true;
      stack += "    " + name + "\n";
    }
    std::free(names);  // NOLINT: backtrace_symbols' contract
    if (in_contours) {
      ++tally.contour_storage;
      tally.largest_contour_storage = std::max(tally.largest_contour_storage, g_recorded[k].size);
    } else {
      tally.others +=
          "frame " + std::to_string(frame) + ": " + std::to_string(g_recorded[k].size) + " bytes at:\n" + stack;
    }
  }
  if (g_large > kMaxRecorded) tally.others += "(and " + std::to_string(g_large - kMaxRecorded) + " more)\n";
}

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() / ("ips_allocations_" + std::to_string(::getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

TEST(FramePathAllocations, SteadyStateFramesAllocateNoImageSizedBuffer) {
  if (!IPS_MALLOC_SHIM) GTEST_SKIP() << "the sanitizers own malloc: the counting shim is not built";
  const Scene scene = test_scene();
  const CameraRenderer r(scene, scene.camera_index("red"));
  const auto& C = r.camera().position;
  Sequence seq{r, {}};
  seq.movers.push_back({.id = 1, .x = C.x() - 0.8, .y = C.y() - 0.4, .vx = 0.8, .turn = 0.5});
  seq.movers.push_back({.id = 2, .x = C.x() + 0.6, .y = C.y() + 0.3, .vx = -0.5, .vy = -0.5});
  seq.movers.push_back({.id = 5, .x = C.x(), .y = C.y() + 0.45, .vy = -0.2, .yaw = 1.0, .turn = -2.0});
  // Comes and goes in the counted frames: an acquisition that finds it, a lost-track search.
  seq.movers.push_back({.id = 9, .x = C.x() + 1.0, .y = C.y() - 0.5, .from = 27, .until = 35});
  constexpr int kFrames = 42;
  TempDir dir;
  for (int f = 0; f < kFrames; ++f) {
    std::vector<ips::sim::MarkerTruth> truth;
    const auto jpeg = seq.jpeg(f, truth);
    char name[32];
    std::snprintf(name, sizeof name, "f%03d.jpg", f);
    std::ofstream(dir.path / name, std::ios::binary)
        .write(reinterpret_cast<const char*>(jpeg.data()), static_cast<std::streamsize>(jpeg.size()));
  }
  ips::install_image_buffer_pool();  // as ipsd does (apps/ipsd/main.cpp)
  // The sequence twice: the first pass warms up (the pool meets every buffer size the scene
  // needs), the second is the steady state and is counted.
  ips::FileSource source({.path = dir.path.string(), .fps = 0, .loop = true, .preload = true, .phase_s = {}});
  ASSERT_TRUE(source.defer_decode(true));
  source.open();
  ips::TrackedFrameDetector detector({}, {}, 0);
  const ips::CameraModel& camera = r.camera().model;
  ips::Frame frame;
  std::vector<ips::MarkerDetection> found;
  int acquisitions = 0, tracked = 0;
  Tally tally;
  ips::ImageBufferPoolStats pool_before;
  for (int f = 0; f < 2 * kFrames; ++f) {
    const bool counted = f >= kFrames;
    if (f == kFrames) pool_before = ips::image_buffer_pool_stats();
    {
      std::optional<Counting> counting;
      if (counted) counting.emplace();
      ASSERT_EQ(source.read(frame, std::chrono::milliseconds(100)), ips::FrameSource::ReadStatus::kFrame);
      ASSERT_TRUE(detector.detect(frame, &camera, false, found)) << detector.error();
      const bool pending = detector.acquisition_pending();
      ASSERT_TRUE(detector.acquire(frame, &camera)) << detector.error();
      if (counted) {
        acquisitions += pending ? 1 : 0;
        tracked += static_cast<int>(found.size());
      }
    }
    if (counted) tally_recorded(f - kFrames, tally);
  }
  const ips::ImageBufferPoolStats pool = ips::image_buffer_pool_stats();
  // The counted frames did the daemon's whole range of work.
  EXPECT_GE(acquisitions, 7) << "periodic searches and lost-track searches";
  // 3 markers throughout and one for 8 frames; the loop's wrap-around moves every marker at
  // once (lost, then searched for and found again): most are reported.
  EXPECT_GE(tracked, (3 * kFrames + 8) * 8 / 10) << "the markers were tracked";
  // Every image-sized Mat came from the pool's free buffers.
  EXPECT_GT(pool.reused - pool_before.reused, static_cast<std::uint64_t>(kFrames));
  EXPECT_EQ(pool.allocated - pool_before.allocated, 0u);
  // Nothing else allocated a buffer of image size: not the JPEG input, not the decoder.
  EXPECT_TRUE(tally.others.empty()) << "image-sized allocations (>= " << kImageSized << " bytes) on the frame path:\n"
                                    << tally.others;
  // OpenCV's contour storage is what it is (above), but never an image's size.
  EXPECT_LT(tally.largest_contour_storage, std::size_t{256} << 10);
  std::printf(
      "steady state, %d frames: %d allocations of OpenCV's contour search (largest %zu bytes), pool %llu "
      "reused, %zu bytes cached\n",
      kFrames, tally.contour_storage, tally.largest_contour_storage,
      static_cast<unsigned long long>(pool.reused - pool_before.reused), pool.cached_bytes);
}

}  // namespace
