#include "ips/capture/file_source.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <thread>

#include <spdlog/spdlog.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/core/clock.h"
#include "ips/core/error.h"

namespace ips {
namespace {

namespace fs = std::filesystem;

bool is_image(const fs::path& p) {
  static const std::set<std::string> kExtensions{".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm"};
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return kExtensions.count(ext) > 0;
}

void to_gray(const cv::Mat& in, cv::Mat& gray) {
  if (in.channels() == 3)
    cv::cvtColor(in, gray, cv::COLOR_BGR2GRAY);
  else if (in.channels() == 4)
    cv::cvtColor(in, gray, cv::COLOR_BGRA2GRAY);
  else
    in.copyTo(gray);
}

}  // namespace

void FileSourceOptions::validate() const {
  if (path.empty()) throw InputError("file source: 'path' is empty");
  if (preload && !std::filesystem::is_directory(path))
    throw InputError("file source: 'preload' needs a directory of images, not " + path);
  if (!(fps >= 0 && fps <= 10000)) throw InputError("file source: 'fps' must be in [0, 10000]");
  if (phase_s && !(*phase_s >= 0 && *phase_s < 1)) throw InputError("file source: 'phase' must be in [0, 1) seconds");
  if (virtual_start_ns != 0 && !(fps > 0))
    throw InputError("file source: virtual time needs a frame rate ('fps' > 0) to stamp the frames");
}

FileSource::FileSource(FileSourceOptions options) : options_(std::move(options)) { options_.validate(); }

std::string FileSource::describe() const { return "file:" + options_.path; }

void FileSource::open() {
  close();
  std::error_code ec;
  if (!fs::exists(options_.path, ec)) throw SourceError(describe() + ": no such file or directory");
  is_directory_ = fs::is_directory(options_.path, ec);
  if (is_directory_) {
    for (const auto& entry : fs::directory_iterator(options_.path, ec))
      if (entry.is_regular_file() && is_image(entry.path())) files_.push_back(entry.path().string());
    std::sort(files_.begin(), files_.end());
    if (files_.empty()) throw SourceError(describe() + ": the directory holds no image");
    if (options_.preload) {
      for (const auto& file : files_) {
        std::ifstream in(file, std::ios::binary);
        std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        if (!in.good() && !in.eof()) throw SourceError(describe() + ": cannot read " + file);
        preloaded_.push_back(std::move(bytes));
      }
      if (!jpeg_) jpeg_ = std::make_unique<JpegDecoder>();
    }
  } else if (!video_.open(options_.path) || !video_.isOpened()) {
    throw SourceError(describe() + ": cannot open as a video");
  }
  next_file_ = 0;
  const std::int64_t now = options_.virtual_start_ns != 0 ? options_.virtual_start_ns : monotonic_ns();
  grid_origin_ns_ = options_.phase_s ? std::llround(*options_.phase_s * 1e9) : now;
  next_due_ = first_due_at_or_after(now);
  open_ = true;
}

void FileSource::close() noexcept {
  open_ = false;
  files_.clear();
  preloaded_.clear();
  if (video_.isOpened()) video_.release();
}

bool FileSource::defer_decode(bool on) {
  defer_decode_ = on && options_.preload;
  return defer_decode_;
}

bool FileSource::read_image(Frame& out, bool& corrupt) {
  cv::Mat& gray = out.gray;
  corrupt = false;
  if (is_directory_) {
    if (next_file_ == files_.size()) {
      if (!options_.loop) return false;
      next_file_ = 0;
    }
    const std::size_t index = next_file_++;
    const std::string& file = files_[index];
    if (options_.preload) {
      const auto& bytes = preloaded_[index];
      const bool jpeg = bytes.size() > 3 && bytes[0] == 0xFF && bytes[1] == 0xD8;
      if (jpeg && defer_decode_) {
        out.set_jpeg(bytes);  // a camera's MJPEG frame, as copied out of its buffer
        return true;
      }
      if (jpeg) {
        if (jpeg_->decode_gray(bytes, gray)) return true;
        spdlog::warn("{}: cannot decode {}: {}; skipped", describe(), file, jpeg_->error());
        corrupt = true;
        return true;
      }
      decoded_ = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
    } else {
      decoded_ = cv::imread(file, cv::IMREAD_UNCHANGED);
    }
    if (decoded_.empty() || decoded_.depth() != CV_8U) {
      spdlog::warn("{}: cannot read {} as an 8-bit image; skipped", describe(), file);
      corrupt = true;
      return true;
    }
  } else if (!video_.read(decoded_)) {
    // End of the video: rewind (reopening, which every backend supports) or stop.
    if (!options_.loop) return false;
    video_.release();
    if (!video_.open(options_.path) || !video_.read(decoded_))
      throw SourceError(describe() + ": cannot read a frame after rewinding");
  }
  to_gray(decoded_, gray);
  return true;
}

std::int64_t FileSource::due_ns(std::int64_t k) const {
  return grid_origin_ns_ + std::llround(static_cast<double>(k) * 1e9 / options_.fps);
}

std::int64_t FileSource::first_due_at_or_after(std::int64_t t_ns) const {
  if (!(options_.fps > 0)) return 0;
  auto k = static_cast<std::int64_t>(std::ceil(static_cast<double>(t_ns - grid_origin_ns_) * options_.fps * 1e-9));
  while (due_ns(k) < t_ns) ++k;  // rounding
  return k;
}

FrameSource::ReadStatus FileSource::read(Frame& out, std::chrono::milliseconds timeout) {
  if (!open_) throw SourceError(describe() + ": read() on a closed source");
  std::int64_t stamp = 0;
  if (options_.virtual_start_ns != 0) {
    stamp = due_ns(next_due_++);  // virtual time: the frame's own grid time, at once
  } else if (options_.fps > 0) {
    const std::int64_t now = monotonic_ns();
    const std::int64_t timeout_ns = std::chrono::nanoseconds(timeout).count();
    const std::int64_t due = due_ns(next_due_);
    if (due > now + timeout_ns) {
      std::this_thread::sleep_for(timeout);
      return ReadStatus::kTimeout;
    }
    if (due > now) std::this_thread::sleep_for(std::chrono::nanoseconds(due - now));
    // A caller that fell behind gets at most one overdue frame at once, not a burst, and the
    // next one on the grid.
    next_due_ = std::max(next_due_ + 1, first_due_at_or_after(monotonic_ns()));
  }
  if (out.gray.u != nullptr && out.gray.u->refcount > 1) out.gray.release();
  out.jpeg.clear();
  bool corrupt = false;
  if (!read_image(out, corrupt)) return ReadStatus::kEnd;
  if (corrupt) return ReadStatus::kCorrupt;
  out.sequence = sequence_++;
  out.t_mono_ns = stamp != 0 ? stamp : monotonic_ns();
  out.t_real_ns = out.t_mono_ns + realtime_minus_monotonic_ns();
  out.t_delivered_ns = out.t_mono_ns;
  return ReadStatus::kFrame;
}

}  // namespace ips
