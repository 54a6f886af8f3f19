// Frames from a video file (anything cv::VideoCapture reads) or a directory of images, for
// replaying recordings through the daemon and for tests. Paced at a fixed rate and
// time-stamped with the clock at read time (a file has no capture clock of its own).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/videoio.hpp>

#include "ips/capture/frame_source.h"
#include "ips/capture/jpeg_decoder.h"

namespace ips {

struct FileSourceOptions {
  /// A video file, or a directory whose images (.png .jpg .jpeg .bmp .tif .tiff .pgm .ppm)
  /// are played in file-name order.
  std::string path;
  /// Playback rate in frames per second: read() waits until the next frame is due.
  /// 0 = no pacing (as fast as the caller reads).
  double fps = 30.0;
  /// true = start again at the end; false = read() returns kEnd after the last frame.
  bool loop = true;
  /// Replay: a directory's files are read into memory when the source opens and each
  /// read() only decodes one (JPEG files with libjpeg-turbo to greyscale, as a USB camera's
  /// MJPEG frame is decoded; other formats with OpenCV): what a real camera costs the daemon,
  /// without disk reads. Memory: the files' total size.
  bool preload = false;
  /// Frames are due on a grid, origin + k / fps: the origin is `phase_s` of the monotonic
  /// clock (0 <= phase < 1 s) when given, else the moment the source opens. File cameras with
  /// different phases deliver apart, as unsynchronised cameras do; the same phase, at once. A
  /// reader that falls behind gets the overdue frame at once and the next one on the grid
  /// again (the phase holds; frames are never skipped).
  std::optional<double> phase_s = std::nullopt;
  /// Virtual time (tests and dry runs; 0 = off): read() never waits. The frames are stamped
  /// with their grid times from this CLOCK_MONOTONIC instant on (the first grid point at or
  /// after it) and handed over at once, as fast as the reader takes them, whatever the
  /// machine's load: none is ever skipped. Needs fps > 0.
  std::int64_t virtual_start_ns = 0;

  /// Throws ips::InputError naming the offending field.
  void validate() const;

  bool operator==(const FileSourceOptions&) const = default;
};

class FileSource : public FrameSource {
 public:
  explicit FileSource(FileSourceOptions options);

  /// Throws ips::SourceError if the path is missing, unreadable, or holds no image.
  void open() override;
  /// kTimeout if the next frame is not due within `timeout`; kCorrupt for an unreadable
  /// image in a directory (skipped); kEnd at the end when not looping.
  ReadStatus read(Frame& out, std::chrono::milliseconds timeout) override;
  void close() noexcept override;
  std::string describe() const override;
  /// Preloaded JPEG files are then handed over undecoded (Frame::jpeg); other formats and
  /// videos are still decoded. True when preload is on.
  bool defer_decode(bool on) override;

 private:
  bool read_image(Frame& out, bool& corrupt);

  FileSourceOptions options_;
  bool open_ = false;
  bool is_directory_ = false;
  std::vector<std::string> files_;
  std::vector<std::vector<std::uint8_t>> preloaded_;  // files_' bytes (preload)
  std::unique_ptr<JpegDecoder> jpeg_;
  std::size_t next_file_ = 0;
  cv::VideoCapture video_;
  cv::Mat decoded_;
  std::uint64_t sequence_ = 0;
  std::int64_t due_ns(std::int64_t k) const;  ///< grid point k, CLOCK_MONOTONIC
  std::int64_t first_due_at_or_after(std::int64_t t_ns) const;
  std::int64_t next_due_ = 0;        // index of the next frame's grid point
  std::int64_t grid_origin_ns_ = 0;  // CLOCK_MONOTONIC
  bool defer_decode_ = false;
};

}  // namespace ips
