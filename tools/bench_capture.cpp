// Capture + decode CPU per camera at 1080p30 MJPEG, through the emulated V4L2 device
// (tests/capture/v4l2_emulator.cpp, preloaded): the real V4L2Source code path — poll,
// DQBUF, greyscale JPEG decode (at scale 1, 1/2, 1/4), QBUF.
//
//   build/release/tools/bench_capture [--frames N] [--emulator path/to/libips_v4l2_emu.so]
//
// The program writes 1080p test frames, then re-executes itself with LD_PRELOAD set (the
// preload must be in place at process start) and measures CLOCK_PROCESS_CPUTIME_ID over
// N frames per configuration. The emulator's copy of each JPEG into the mmap buffer (what
// the kernel driver would do) is included in the figures.
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/capture/jpeg_decoder.h"
#include "ips/capture/v4l2_source.h"

extern char** environ;

namespace {

namespace fs = std::filesystem;
constexpr const char* kDevice = "/dev/video-bench0";

double cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + ts.tv_nsec * 1e-9;
}

double wall_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + ts.tv_nsec * 1e-9;
}

// A lab-floor-like 1080p frame: smooth texture, sensor noise, a few high-contrast marker-like
// squares, so that the JPEG size and decode cost resemble a real ceiling camera's.
cv::Mat scene(int k) {
  cv::RNG rng(static_cast<std::uint64_t>(1234 + k));
  cv::Mat small(68, 120, CV_8UC3);
  rng.fill(small, cv::RNG::UNIFORM, 60, 190);
  cv::Mat img;
  cv::resize(small, img, cv::Size(1920, 1080), 0, 0, cv::INTER_CUBIC);
  for (int m = 0; m < 6; ++m) {
    const cv::Point p(rng.uniform(100, 1700), rng.uniform(100, 900));
    cv::rectangle(img, cv::Rect(p, cv::Size(120, 120)), cv::Scalar::all(0), cv::FILLED);
    for (int c = 0; c < 16; ++c)
      if (rng.uniform(0, 2))
        cv::rectangle(img, cv::Rect(p + cv::Point(20 + (c % 4) * 20, 20 + (c / 4) * 20), cv::Size(20, 20)),
                      cv::Scalar::all(255), cv::FILLED);
  }
  cv::Mat noise(img.size(), img.type());
  rng.fill(noise, cv::RNG::NORMAL, 0, 4);
  img += noise;
  return img;
}

int parent(int argc, char** argv, const std::string& emulator) {
  const fs::path work = fs::temp_directory_path() / ("ips-bench-capture-" + std::to_string(getpid()));
  fs::create_directories(work / "frames");
  std::size_t bytes = 0;
  for (int k = 0; k < 8; ++k) {
    std::vector<std::uint8_t> jpeg;
    cv::imencode(".jpg", scene(k), jpeg, {cv::IMWRITE_JPEG_QUALITY, 85});
    std::ofstream((work / "frames" / fmt::format("f{}.jpg", k)).string(), std::ios::binary)
        .write(reinterpret_cast<const char*>(jpeg.data()), static_cast<std::streamsize>(jpeg.size()));
    bytes += jpeg.size();
  }
  std::printf("frames: 1920x1080 MJPEG, quality 85, mean %.0f kB\n", bytes / 8.0 / 1000.0);
  std::ofstream((work / "cam.conf").string())
      << "formats=MJPG\nsizes=1920x1080\nfps=30\nframes=" << (work / "frames").string() << "\n";

  std::fflush(stdout);
  std::vector<std::string> env;
  for (char** e = environ; *e; ++e) env.emplace_back(*e);
  env.push_back("LD_PRELOAD=" + emulator);
  env.push_back("IPS_V4L2_EMU_DEVICES=" + std::string(kDevice) + "=" + (work / "cam.conf").string());
  env.push_back("IPS_BENCH_CAPTURE_FRAMES_DIR=" + (work / "frames").string());
  std::vector<char*> envp;
  for (auto& s : env) envp.push_back(s.data());
  envp.push_back(nullptr);
  pid_t pid = 0;
  int status = 1;
  if (posix_spawn(&pid, "/proc/self/exe", nullptr, nullptr, argv, envp.data()) == 0) waitpid(pid, &status, 0);
  fs::remove_all(work);
  (void)argc;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 1;
}

int child(int frames) {
  spdlog::set_level(spdlog::level::warn);
  std::printf("%-32s %12s %14s %16s\n", "configuration", "CPU ms/frame", "CPU % @30fps", "decode alone");

  // Decode alone, same JPEGs, for the split.
  std::vector<std::vector<std::uint8_t>> jpegs;
  for (const auto& e : fs::directory_iterator(std::getenv("IPS_BENCH_CAPTURE_FRAMES_DIR"))) {
    std::ifstream in(e.path().string(), std::ios::binary);
    jpegs.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  for (int scale : {1, 2, 4}) {
    ips::JpegDecoder decoder;
    cv::Mat gray;
    const int n = 60;
    const double c0 = cpu_seconds();
    for (int i = 0; i < n; ++i) decoder.decode_gray(jpegs[static_cast<std::size_t>(i) % jpegs.size()], gray, scale);
    const double decode_ms = (cpu_seconds() - c0) / n * 1e3;

    ips::V4L2Options options;
    options.device = kDevice;
    options.decode_scale = scale;
    ips::V4L2Source source(options);
    source.open();
    ips::Frame frame;
    auto grab = [&](int count) {
      for (int got = 0; got < count;)
        got += source.read(frame, std::chrono::milliseconds(1000)) == ips::FrameSource::ReadStatus::kFrame;
    };
    grab(5);  // warm-up: first buffers, decoder state
    const double w0 = wall_seconds(), t0 = cpu_seconds();
    grab(frames);
    const double cpu = cpu_seconds() - t0, wall = wall_seconds() - w0;
    source.close();
    const std::string name = fmt::format("capture+decode 1/{} ({}x{})", scale, frame.gray.cols, frame.gray.rows);
    std::printf("%-32s %12.2f %13.1f%% %13.2f ms\n", name.c_str(), cpu / frames * 1e3, 100.0 * cpu / wall, decode_ms);
    if (source.stats().driver_drops > 0)
      std::printf("  (%llu frames dropped by the driver)\n",
                  static_cast<unsigned long long>(source.stats().driver_drops));
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 150;
  std::string emulator =
      (fs::canonical("/proc/self/exe").parent_path().parent_path() / "tests" / "libips_v4l2_emu.so").string();
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string arg = argv[i];
    if (arg == "--frames")
      frames = std::atoi(argv[i + 1]);
    else if (arg == "--emulator")
      emulator = argv[i + 1];
    else {
      std::fprintf(stderr, "usage: bench_capture [--frames N] [--emulator libips_v4l2_emu.so]\n");
      return 2;
    }
  }
  if (frames <= 0) {
    std::fprintf(stderr, "bench_capture: --frames must be positive\n");
    return 2;
  }
  if (std::getenv("IPS_BENCH_CAPTURE_FRAMES_DIR") != nullptr) return child(frames);
  if (!fs::exists(emulator)) {
    std::fprintf(stderr, "bench_capture: emulator %s not found (build target ips_v4l2_emu, or --emulator)\n",
                 emulator.c_str());
    return 2;
  }
  return parent(argc, argv, emulator);
}
