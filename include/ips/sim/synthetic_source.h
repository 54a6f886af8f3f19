// A FrameSource that renders one camera of a simulated Scene (moving markers, exact truth).
//
// Time: frame k is captured at scene time t_k = phase + k / fps (phase 0 unless set). Scene time 0 is the
// CLOCK_MONOTONIC instant `epoch_mono_ns`, so frame k carries t_mono_ns = epoch + round(k * 1e9 / fps) and
// scene_time(t_mono_ns) recovers t_k. Several sources of the same scene given the same epoch
// (one per camera) therefore agree on the scene time of any capture time, and the truth of a
// frame is scene.marker_pose(id, source.scene_time(frame.t_mono_ns)).
//
// Buffers: read() renders/decodes into `out.gray`, reusing its buffer when it is the same
// size, like the other sources: keep a frame beyond the next read() by cloning it (or by
// passing a fresh Frame).
//
// Pacing: `realtime` sleeps until each frame's capture time, like a camera; if rendering
// falls behind, frames are skipped (sequence numbers jump, as with driver drops). Otherwise
// frames come as fast as they render, still stamped with their simulated capture times.
//
// Render ahead (`render_ahead`, realtime only; what the daemon uses): a thread of its own
// ("sim:<camera>", niced, so it runs on spare CPU) renders and JPEG-encodes frames before
// they are due, up to kAhead frames; read() hands frame k over at its capture time plus
// `transport_delay_ns` (like MJPEG arriving over USB one frame period after the exposure) and
// decodes it there, as a USB camera's reader does. So a reader's cost is the decode, not the
// renderer. Frame::t_delivered_ns is the hand-over time (later than due if rendering fell behind).
// A scene with a hand-placed marker (`placements` trajectory: outside state, read when the
// frame is rendered) renders each frame no earlier than its capture time instead, so a frame
// never shows the marker where it lay before it was moved.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "ips/capture/frame_source.h"
#include "ips/capture/jpeg_decoder.h"
#include "ips/sim/renderer.h"
#include "ips/sim/scene.h"

namespace ips::sim {

struct SyntheticSourceOptions {
  std::string camera;              ///< camera name in the scene
  double fps = 30.0;               ///< frame rate, frames per second of scene time
  bool realtime = true;            ///< pace on CLOCK_MONOTONIC (true) or as fast as possible
  std::int64_t epoch_mono_ns = 0;  ///< CLOCK_MONOTONIC of scene time 0; 0 = monotonic_ns() at open()
  std::uint64_t max_frames = 0;    ///< read() returns kEnd after this many frames; 0 = endless
  bool colour_jpeg = false;        ///< encode as 3-channel MJPEG like a USB camera (slower) or 1-channel
  bool render_ahead = false;       ///< realtime only: render on a thread of its own, deliver with a delay
  std::int64_t transport_delay_ns = -1;
  std::int64_t phase_ns = 0;  ///< frame k is captured at scene time phase + k / fps (unsynchronised cameras)  ///<
                              ///< render_ahead: capture -> delivery, ns; -1 = one frame period
};

class SyntheticSource : public FrameSource {
 public:
  /// Throws ips::InputError for an unknown camera name or fps <= 0. Builds the camera's
  /// renderer (ray map, background): ~0.3 s at 1080p.
  SyntheticSource(std::shared_ptr<const Scene> scene, SyntheticSourceOptions options);

  ~SyntheticSource() override;
  SyntheticSource(const SyntheticSource&) = delete;
  SyntheticSource& operator=(const SyntheticSource&) = delete;

  void open() override;
  ReadStatus read(Frame& out, std::chrono::milliseconds timeout) override;
  void close() noexcept override;
  std::string describe() const override;
  /// JPEG frames (jpeg_quality > 0) are then handed over undecoded (Frame::jpeg), as a
  /// real MJPEG camera's. True when the scene encodes JPEG.
  bool defer_decode(bool on) override;

  /// Scene time (seconds) of a capture time stamped by this source.
  double scene_time(std::int64_t t_mono_ns) const { return static_cast<double>(t_mono_ns - epoch_mono_ns_) * 1e-9; }
  std::int64_t epoch_mono_ns() const { return epoch_mono_ns_; }
  /// Truth of every scene marker in this camera at a frame's capture time.
  std::vector<MarkerTruth> truth(std::int64_t t_mono_ns) const { return renderer_.truth(scene_time(t_mono_ns)); }
  /// The JPEG bytes of the last frame (empty when the scene's jpeg_quality is 0).
  const std::vector<std::uint8_t>& last_jpeg() const { return jpeg_; }
  const CameraRenderer& renderer() const { return renderer_; }
  const Scene& scene() const { return *scene_; }

 private:
  std::int64_t frame_time_ns(std::uint64_t k) const;
  void render_loop();
  ReadStatus read_ahead(Frame& out, std::chrono::milliseconds timeout);

  static constexpr std::size_t kAhead = 2;  ///< frames rendered ahead at most
  bool external_state_ = false;             ///< the scene has a hand-placed marker: render at capture time, not before
  struct Rendered {
    std::uint64_t k = 0;
    std::vector<std::uint8_t> jpeg;  ///< or, with jpeg_quality 0:
    cv::Mat gray;
    std::int64_t ready_ns = 0;  ///< when rendering finished
  };
  std::thread render_thread_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Rendered> ready_;
  bool stop_render_ = false;
  std::int64_t delay_ns_ = 0;

  std::shared_ptr<const Scene> scene_;
  SyntheticSourceOptions options_;
  CameraRenderer renderer_;
  JpegDecoder decoder_;
  cv::Mat rendered_;
  std::vector<std::uint8_t> jpeg_;
  bool open_ = false;
  bool defer_decode_ = false;
  std::int64_t epoch_mono_ns_ = 0;
  std::int64_t real_minus_mono_ns_ = 0;
  std::uint64_t next_ = 0;  ///< index of the next frame
  std::uint64_t delivered_ = 0;
};

}  // namespace ips::sim
