// Runs ips::V4L2Source in a child process that has the V4L2 emulator preloaded, and prints
// what it saw as `key=value` lines for capture_test.cpp to check.
//   capture: open, read --frames frames (dumping them as PNG if --dump-dir), print stats
//   unplug:  open/read, then --cycles times: unplug (control file) -> read must throw
//            SourceError -> open must throw -> replug -> open + read a frame; prints the
//            fd and buffer-mapping counts before and after (leak check)
//   raw:     the emulator's own semantics through bare ioctl/mmap/poll/select calls
//   two:     two cameras (--device and --device2), one thread each, reopening on failure;
//            unplugs the first and checks that the second keeps delivering, then replugs
#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/select.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>

#include "emu_control.h"
#include "ips/capture/v4l2_source.h"
#include "ips/core/clock.h"
#include "ips/core/error.h"

namespace {

using Status = ips::FrameSource::ReadStatus;

int count_fds() {
  int n = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator("/proc/self/fd")) ++n;
  return n;
}

// Mappings of the emulator's buffer memory (its memfd is named ips-v4l2-emu).
int count_buffer_maps() {
  std::ifstream maps("/proc/self/maps");
  int n = 0;
  for (std::string line; std::getline(maps, line);) n += line.find("ips-v4l2-emu") != std::string::npos;
  return n;
}

// Reads until a frame arrives; returns false after `limit` non-frame results.
bool read_frame(ips::V4L2Source& source, ips::Frame& frame, int limit = 200) {
  for (int i = 0; i < limit; ++i)
    if (source.read(frame, std::chrono::milliseconds(100)) == Status::kFrame) return true;
  return false;
}

void print_granted(const ips::V4L2Source& s) {
  const auto& g = s.granted();
  std::printf("granted format=%s width=%d height=%d fps=%.3f buffers=%d driver=%s card=%s",
              g.format == ips::PixelFormat::kMjpeg ? "MJPEG" : "YUYV", g.width, g.height, g.fps, g.buffer_count,
              g.driver.c_str(), g.card.c_str());
  if (g.exposure_s) std::printf(" exposure_s=%.4f", *g.exposure_s);
  if (g.gain) std::printf(" gain=%d", *g.gain);
  if (g.autofocus) std::printf(" autofocus=%d", *g.autofocus ? 1 : 0);
  if (g.power_line_hz) std::printf(" power_line_hz=%d", *g.power_line_hz);
  std::printf("\n");
}

int capture(ips::V4L2Source& source, int frames, const std::string& dump_dir) {
  source.open();
  print_granted(source);
  ips::Frame frame;
  int got = 0, attempts = 0;
  while (got < frames && attempts++ < 50 * frames + 100) {
    const Status status = source.read(frame, std::chrono::milliseconds(200));
    if (status == Status::kCorrupt) std::printf("corrupt\n");
    if (status != Status::kFrame) continue;
    ++got;
    std::printf("frame seq=%llu mono=%lld real=%lld read_mono=%lld offset=%lld width=%d height=%d\n",
                static_cast<unsigned long long>(frame.sequence), static_cast<long long>(frame.t_mono_ns),
                static_cast<long long>(frame.t_real_ns), static_cast<long long>(ips::monotonic_ns()),
                static_cast<long long>(ips::realtime_minus_monotonic_ns()), frame.gray.cols, frame.gray.rows);
    if (!dump_dir.empty()) cv::imwrite(dump_dir + "/frame_" + std::to_string(frame.sequence) + ".png", frame.gray);
  }
  const auto& st = source.stats();
  std::printf("stats frames=%llu corrupt=%llu drops=%llu\n", static_cast<unsigned long long>(st.frames),
              static_cast<unsigned long long>(st.corrupt), static_cast<unsigned long long>(st.driver_drops));
  source.close();
  return got == frames ? 0 : 1;
}

int unplug(ips::V4L2Source& source, const std::string& control, int cycles) {
  const int fds_before = count_fds();
  const int maps_before = count_buffer_maps();
  ips::Frame frame;
  source.open();
  std::printf("maps_open=%d\n", count_buffer_maps());
  if (!read_frame(source, frame)) return 1;
  for (int c = 0; c < cycles; ++c) {
    ips::test::set_emu_control(control, "present", "0");
    try {
      for (int i = 0; i < 100; ++i) source.read(frame, std::chrono::milliseconds(100));
      std::printf("error: read kept working after unplug\n");
      return 1;
    } catch (const ips::SourceError& e) {
      if (c == 0) std::printf("read_error=%s open_after=%d\n", e.what(), source.is_open() ? 1 : 0);
    }
    try {
      source.open();
      std::printf("error: open worked while unplugged\n");
      return 1;
    } catch (const ips::SourceError& e) {
      if (c == 0) std::printf("open_error=%s\n", e.what());
    }
    ips::test::set_emu_control(control, "present", "1");
    source.open();
    if (!read_frame(source, frame)) return 1;
  }
  std::printf("replugged_frames=%llu opens=%llu\n", static_cast<unsigned long long>(source.stats().frames),
              static_cast<unsigned long long>(source.stats().opens));
  source.close();
  std::printf("fds_before=%d fds_after=%d maps_before=%d maps_after=%d\n", fds_before, count_fds(), maps_before,
              count_buffer_maps());
  return 0;
}

// Streams a 160x120 YUYV device by hand and prints what each step returned.
int raw(const std::string& device) {
  const int fd = ::open(device.c_str(), O_RDWR | O_NONBLOCK);
  if (fd < 0) return 1;
  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  fmt.fmt.pix = {160, 120, V4L2_PIX_FMT_YUYV, V4L2_FIELD_ANY, 0, 0, 0, 0, 0, {0}, 0, 0};
  v4l2_requestbuffers req{};
  req.count = 4;
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  if (::ioctl(fd, VIDIOC_S_FMT, &fmt) != 0 || ::ioctl(fd, VIDIOC_REQBUFS, &req) != 0) return 1;
  std::vector<std::uint8_t*> mem;
  for (std::uint32_t i = 0; i < req.count; ++i) {
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    b.index = i;
    if (::ioctl(fd, VIDIOC_QUERYBUF, &b) != 0) return 1;
    void* p = ::mmap(nullptr, b.length, PROT_READ, MAP_SHARED, fd, b.m.offset);
    if (p == MAP_FAILED || ::ioctl(fd, VIDIOC_QBUF, &b) != 0) return 1;
    mem.push_back(static_cast<std::uint8_t*>(p));
  }
  pollfd pfd{fd, POLLIN, 0};
  std::printf("poll_before_streamon=%s\n", ::poll(&pfd, 1, 0) == 1 && (pfd.revents & POLLERR) ? "POLLERR" : "other");
  v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (::ioctl(fd, VIDIOC_STREAMON, &type) != 0) return 1;
  const std::int64_t t_on = ips::monotonic_ns();
  v4l2_buffer b{};
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.memory = V4L2_MEMORY_MMAP;
  const int early = ::ioctl(fd, VIDIOC_DQBUF, &b);
  std::printf("dqbuf_early=%s\n", early == -1 && errno == EAGAIN ? "EAGAIN" : "other");
  fd_set readable;
  FD_ZERO(&readable);
  FD_SET(fd, &readable);
  timeval timeout{5, 0};
  const int selected = ::select(fd + 1, &readable, nullptr, nullptr, &timeout);
  std::printf("select=%d isset=%d\n", selected, FD_ISSET(fd, &readable) ? 1 : 0);
  if (::ioctl(fd, VIDIOC_DQBUF, &b) != 0) return 1;
  const std::int64_t ts = b.timestamp.tv_sec * 1'000'000'000LL + b.timestamp.tv_usec * 1000LL;
  const std::uint8_t* y = mem[b.index] + 2 * fmt.fmt.pix.bytesperline;  // row 2
  std::printf("seq=%u monotonic=%d ts_after_streamon_ns=%lld bytesused=%u y32=%d\n", b.sequence,
              (b.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC ? 1 : 0,
              static_cast<long long>(ts - t_on), b.bytesused, y[2 * 3]);
  ::ioctl(fd, VIDIOC_STREAMOFF, &type);
  for (std::uint8_t* p : mem) ::munmap(p, fmt.fmt.pix.sizeimage);
  ::close(fd);
  return 0;
}

// One camera thread: read frames, reopen (after a short pause) whenever the source fails.
struct CameraThread {
  explicit CameraThread(ips::V4L2Options options) : source(std::move(options)) {}
  void run() {
    ips::Frame frame;
    while (!stop) {
      if (!source.is_open()) {
        try {
          source.open();
        } catch (const ips::SourceError&) {
          std::this_thread::sleep_for(std::chrono::milliseconds(50));
          continue;
        }
      }
      try {
        if (source.read(frame, std::chrono::milliseconds(100)) == Status::kFrame) ++frames;
      } catch (const ips::SourceError&) {
        ++failures;
      }
    }
    source.close();
  }
  ips::V4L2Source source;
  std::atomic<std::uint64_t> frames{0}, failures{0};
  std::atomic<bool> stop{false};
};

// Waits (up to 20 s, only reached on failure) for `done` to hold.
bool wait_for(const std::function<bool()>& done) {
  for (int i = 0; i < 2000 && !done(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  return done();
}

int two_cameras(const ips::V4L2Options& options, const std::string& device2, const std::string& control) {
  ips::V4L2Options options2 = options;
  options2.device = device2;
  CameraThread cam0(options), cam1(options2);
  std::thread t0([&] { cam0.run(); }), t1([&] { cam1.run(); });
  int rc = 0;
  auto check = [&](bool ok, const char* what) {
    if (!ok) {
      std::printf("error: %s\n", what);
      rc = 1;
    }
    return ok;
  };
  if (check(wait_for([&] { return cam0.frames >= 5 && cam1.frames >= 5; }), "both cameras streaming")) {
    ips::test::set_emu_control(control, "present", "0");
    if (check(wait_for([&] { return cam0.failures >= 1; }), "unplug detected")) {
      const std::uint64_t f0 = cam0.frames, f1 = cam1.frames;
      check(wait_for([&] { return cam1.frames >= f1 + 20; }), "second camera keeps delivering");
      std::printf("during_unplug cam0=%llu cam1=%llu\n", static_cast<unsigned long long>(cam0.frames - f0),
                  static_cast<unsigned long long>(cam1.frames - f1));
      ips::test::set_emu_control(control, "present", "1");
      const bool resumed = wait_for([&] { return cam0.frames >= f0 + 5; });
      std::printf("resumed=%d cam0_opens=%llu cam1_opens=%llu\n", resumed ? 1 : 0,
                  static_cast<unsigned long long>(cam0.source.stats().opens),
                  static_cast<unsigned long long>(cam1.source.stats().opens));
    }
  }
  cam0.stop = cam1.stop = true;
  t0.join();
  t1.join();
  return rc;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"V4L2Source test driver (run under the V4L2 emulator)"};
  std::string mode, format = "mjpeg", dump_dir, control;
  ips::V4L2Options options;
  int frames = 10, cycles = 1;
  std::string device2;
  app.add_option("mode", mode)->required()->check(CLI::IsMember({"capture", "unplug", "two", "raw"}));
  app.add_option("--device", options.device)->required();
  app.add_option("--device2", device2);
  app.add_option("--width", options.width);
  app.add_option("--height", options.height);
  app.add_option("--fps", options.fps);
  app.add_option("--format", format)->check(CLI::IsMember({"mjpeg", "yuyv"}));
  app.add_option("--buffers", options.buffer_count);
  app.add_option("--scale", options.decode_scale);
  app.add_option("--frames", frames);
  app.add_option("--dump-dir", dump_dir);
  app.add_option("--control", control);
  app.add_option("--cycles", cycles);
  double exposure = 0;
  int gain = -1, autofocus = -1, power_line = -1;
  app.add_option("--exposure", exposure);
  app.add_option("--gain", gain);
  app.add_option("--autofocus", autofocus);
  app.add_option("--power-line", power_line);
  CLI11_PARSE(app, argc, argv);
  options.format = format == "mjpeg" ? ips::PixelFormat::kMjpeg : ips::PixelFormat::kYuyv;
  if (exposure > 0) options.controls.exposure_s = exposure;
  if (gain >= 0) options.controls.gain = gain;
  if (autofocus >= 0) options.controls.autofocus = autofocus != 0;
  if (power_line >= 0) options.controls.power_line_hz = power_line;
  spdlog::set_default_logger(spdlog::stderr_logger_st("driver"));  // stdout is for results
  spdlog::set_level(spdlog::level::warn);
  spdlog::set_pattern("%l: %v");
  try {
    ips::V4L2Source source(options);
    std::setvbuf(stdout, nullptr, _IOLBF, 0);
    if (mode == "two") return two_cameras(options, device2, control);
    if (mode == "raw") return raw(options.device);
    return mode == "capture" ? capture(source, frames, dump_dir) : unplug(source, control, cycles);
  } catch (const std::exception& e) {
    std::printf("exception=%s\n", e.what());
    return 3;
  }
}
