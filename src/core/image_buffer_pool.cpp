#include "ips/core/image_buffer_pool.h"

#include <algorithm>
#include <array>
#include <bit>
#include <mutex>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#if defined(__has_include)
#if __has_include(<sanitizer/asan_interface.h>)
#include <sanitizer/asan_interface.h>  // the pool's free buffers are poisoned under ASan
#endif
#endif
#ifndef ASAN_POISON_MEMORY_REGION
#define ASAN_POISON_MEMORY_REGION(addr, size) ((void)(addr), (void)(size))
#define ASAN_UNPOISON_MEMORY_REGION(addr, size) ((void)(addr), (void)(size))
#endif

namespace ips {
namespace {

constexpr int kMinOctave = 15;  // 32 KiB: below, a Mat is a few rows or a marker's cells
constexpr int kMaxOctave = 40;  // 1 TiB: nothing an image needs
constexpr int kStepsPerOctave = 8;
constexpr int kClasses = (kMaxOctave - kMinOctave) * kStepsPerOctave;
// A request may take a free buffer up to this many classes above its own (<= ~1.5x its size).
constexpr int kLookAbove = 4;

std::size_t capacity_of(int cls) {
  const int octave = kMinOctave + cls / kStepsPerOctave;
  return static_cast<std::size_t>(kStepsPerOctave + cls % kStepsPerOctave) << (octave - 3);
}

// The smallest class whose buffers hold `bytes`; -1 when not pooled.
int class_of(std::size_t bytes) {
  if (bytes < (std::size_t{1} << kMinOctave)) return -1;
  const int octave = std::bit_width(bytes) - 1;
  if (octave >= kMaxOctave) return -1;
  const std::size_t step = std::size_t{1} << (octave - 3);
  const auto k = static_cast<int>((bytes - (std::size_t{1} << octave) + step - 1) / step);  // 0..8
  return (octave - kMinOctave) * kStepsPerOctave + k;  // k == 8 is the next octave's first class
}

class ImageBufferPool final : public cv::MatAllocator {
 public:
  explicit ImageBufferPool(std::size_t max_cached) : max_cached_(max_cached) {}

  // A lower bound frees what the pool holds beyond it (the largest buffers first).
  void set_max_cached(std::size_t bytes) {
    std::vector<std::pair<void*, std::size_t>> excess;
    {
      std::lock_guard lock(mutex_);
      max_cached_ = bytes;
      for (int c = kClasses - 1; c >= 0 && stats_.cached_bytes > max_cached_; --c) {
        auto& list = free_[static_cast<std::size_t>(c)];
        while (!list.empty() && stats_.cached_bytes > max_cached_) {
          excess.emplace_back(list.back(), capacity_of(c));
          list.pop_back();
          stats_.cached_bytes -= capacity_of(c);
          ++stats_.released;
        }
      }
    }
    for (const auto& [buffer, capacity] : excess) {
      ASAN_UNPOISON_MEMORY_REGION(buffer, capacity);
      cv::fastFree(buffer);
    }
  }

  ImageBufferPoolStats stats() const {
    std::lock_guard lock(mutex_);
    return stats_;
  }

  cv::UMatData* allocate(int dims, const int* sizes, int type, void* data, std::size_t* step, cv::AccessFlag flags,
                         cv::UMatUsageFlags usage) const override {
    // The layout as OpenCV's own allocator computes it: dense rows, last dimension fastest.
    std::size_t total = CV_ELEM_SIZE(type);
    for (int i = dims - 1; i >= 0; --i) {
      if (step != nullptr) step[i] = total;
      total *= static_cast<std::size_t>(sizes[i]);
    }
    const int cls = class_of(total);
    // A Mat over the caller's memory, or a small one: OpenCV's allocator as usual (it frees
    // what it made: a Mat remembers its allocator).
    if (data != nullptr || cls < 0) return std_->allocate(dims, sizes, type, data, step, flags, usage);
    const Taken taken = take(cls, total);
    auto* u = new cv::UMatData(this);
    u->data = u->origdata = static_cast<uchar*>(taken.buffer);
    u->size = total;
    u->allocatorFlags_ = taken.cls;  // the class of the buffer (>= the request's): where it goes back
    return u;
  }

  bool allocate(cv::UMatData* u, cv::AccessFlag, cv::UMatUsageFlags) const override { return u != nullptr; }

  void deallocate(cv::UMatData* u) const override {
    if (u == nullptr) return;
    CV_Assert(u->urefcount == 0 && u->refcount == 0);
    give_back(u->allocatorFlags_, u->origdata);
    delete u;
  }

 private:
  struct Taken {
    void* buffer;
    int cls;
  };

  // A free buffer of class `cls` or a little above, else a new one of class `cls`. Under ASan
  // only the `bytes` asked for are addressable: an overrun into the slack is reported.
  Taken take(int cls, std::size_t bytes) const {
    {
      std::lock_guard lock(mutex_);
      for (int c = cls; c < std::min(cls + kLookAbove + 1, kClasses); ++c) {
        auto& list = free_[static_cast<std::size_t>(c)];
        if (list.empty()) continue;
        void* buffer = list.back();
        list.pop_back();
        stats_.cached_bytes -= capacity_of(c);
        stats_.in_use_bytes += capacity_of(c);
        ++stats_.reused;
        ASAN_UNPOISON_MEMORY_REGION(buffer, bytes);
        return {buffer, c};
      }
      ++stats_.allocated;
      stats_.in_use_bytes += capacity_of(cls);
    }
    void* buffer = cv::fastMalloc(capacity_of(cls));
    ASAN_POISON_MEMORY_REGION(static_cast<char*>(buffer) + bytes, capacity_of(cls) - bytes);
    return {buffer, cls};
  }

  // Into the pool while it holds less than its bound, else back to the heap.
  void give_back(int cls, void* buffer) const {
    const std::size_t capacity = capacity_of(cls);
    {
      std::lock_guard lock(mutex_);
      stats_.in_use_bytes -= capacity;
      if (stats_.cached_bytes + capacity <= max_cached_) {
        ASAN_POISON_MEMORY_REGION(buffer, capacity);
        free_[static_cast<std::size_t>(cls)].push_back(buffer);
        stats_.cached_bytes += capacity;
        return;
      }
      ++stats_.released;
    }
    ASAN_UNPOISON_MEMORY_REGION(buffer, capacity);
    cv::fastFree(buffer);
  }

  cv::MatAllocator* std_ = cv::Mat::getStdAllocator();
  mutable std::mutex mutex_;
  mutable std::array<std::vector<void*>, kClasses> free_;
  mutable ImageBufferPoolStats stats_;
  std::size_t max_cached_;
};

// Never destroyed: Mats made from it may be freed after main() returns (static objects).
ImageBufferPool* g_pool = nullptr;
std::mutex g_install_mutex;

}  // namespace

void install_image_buffer_pool(std::size_t max_cached_bytes) {
  std::lock_guard lock(g_install_mutex);
  if (g_pool != nullptr) {
    g_pool->set_max_cached(max_cached_bytes);
    return;
  }
  g_pool = new ImageBufferPool(max_cached_bytes);  // NOLINT: immortal on purpose (above)
  cv::Mat::setDefaultAllocator(g_pool);
}

bool image_buffer_pool_installed() {
  std::lock_guard lock(g_install_mutex);
  return g_pool != nullptr;
}

ImageBufferPoolStats image_buffer_pool_stats() {
  std::lock_guard lock(g_install_mutex);
  return g_pool != nullptr ? g_pool->stats() : ImageBufferPoolStats{};
}

}  // namespace ips
