// Image buffers that are reused instead of allocated: an OpenCV Mat allocator that keeps the
// freed buffers of image size (>= 32 KiB) in a pool and hands them out again.
//
// Why: every frame allocates image-sized scratch inside OpenCV (cv::aruco::detectMarkers
// copies its input and thresholds it; findContours copies the threshold image with a border;
// resize and adaptiveThreshold write into fresh Mats). From malloc those are page faults and
// heap-lock traffic on every frame, and a heap that grows in steps when cameras are restarted.
// From the pool, the steady state allocates nothing image-sized
// (tests/allocations/frame_path_allocations_test.cpp counts it).
//
// Buffers are kept in size classes 1/8 of an octave apart (<= 12.5 % slack); a request takes
// a buffer of its class or of one of the next classes up (a marker's region grows a little
// as it moves), so a region whose size wanders reuses one buffer. What the pool keeps is
// bounded (`max_cached_bytes`): a buffer freed beyond it goes back to the heap.
// Thread-safe; one pool serves the process (Mats move between threads).
#pragma once

#include <cstddef>
#include <cstdint>

namespace ips {

struct ImageBufferPoolStats {
  std::uint64_t reused = 0;      ///< requests served from the pool
  std::uint64_t allocated = 0;   ///< requests that had to allocate (the pool had no buffer)
  std::uint64_t released = 0;    ///< buffers returned to the heap (the pool was full)
  std::size_t cached_bytes = 0;  ///< held by the pool now, free
  std::size_t in_use_bytes = 0;  ///< handed out now (pooled sizes only)
};

/// Makes the pool OpenCV's default Mat allocator (cv::Mat::setDefaultAllocator), once per
/// process; later calls only change the bound (freeing what it holds beyond a lower one).
/// Call before threads start. The pool lives until the process ends (Mats made from it may
/// outlive main()).
void install_image_buffer_pool(std::size_t max_cached_bytes = std::size_t{256} << 20);

/// Whether install_image_buffer_pool() ran, and the pool's counters (zeros if not).
bool image_buffer_pool_installed();
ImageBufferPoolStats image_buffer_pool_stats();

}  // namespace ips
