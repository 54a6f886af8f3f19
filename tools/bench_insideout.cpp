// Inside-out localisation cost per 1080p frame (the paper: 16 ms per frame): the robot's
// up-facing fisheye under config/scenes/insideout_lab.yaml's ceiling (24 markers, ~9 in view),
// 16 rendered frames of its 1.5 m/s drive, JPEG as a USB camera sends them.
//   full:     JPEG decode + whole-frame detection + localise (every frame searched whole)
//   detect:   whole-frame detection alone, on decoded frames
//   localise: the pose from one frame's detections alone (IPPE seeds + LM + covariance)
// Run: build/release/tools/bench_insideout   (from the source tree's root or with IPS_CONFIG_DIR)
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "ips/capture/jpeg_decoder.h"
#include "ips/detect/detector.h"
#include "ips/insideout/localise.h"
#include "ips/sim/ceiling.h"
#include "ips/sim/renderer.h"

namespace {

struct Drive {
  ips::sim::Scene scene;
  ips::CeilingMap map;
  ips::CameraModel lens;
  std::vector<std::vector<std::uint8_t>> jpegs;
  std::vector<cv::Mat> frames;
  std::vector<std::vector<ips::MarkerDetection>> detections;
};

const Drive& drive() {
  static const Drive d = [] {
    const char* dir = std::getenv("IPS_CONFIG_DIR");
    Drive out;
    out.scene = ips::sim::Scene::load(std::string(dir != nullptr ? dir : "config") + "/scenes/insideout_lab.yaml");
    const std::size_t cam = out.scene.camera_index("up");
    out.lens = out.scene.cameras[cam].model;
    out.map = ips::sim::ceiling_map(out.scene);
    const ips::sim::CameraRenderer renderer(out.scene, cam);
    ips::DetectorOptions options;
    options.dictionary = out.map.dictionary;
    ips::Detector detector(options);
    ips::JpegDecoder decoder;
    cv::Mat gray;
    for (int k = 0; k < 16; ++k) {
      renderer.render(k * 0.25, gray, static_cast<std::uint64_t>(k));
      out.jpegs.push_back(ips::sim::encode_jpeg(gray, out.scene.render.jpeg_quality, true));
      cv::Mat decoded;
      decoder.decode_gray(out.jpegs.back(), decoded);
      out.detections.push_back(detector.detect(decoded, &out.lens));
      out.frames.push_back(decoded);
    }
    return out;
  }();
  return d;
}

void full(benchmark::State& state) {
  const Drive& d = drive();
  ips::DetectorOptions options;
  options.dictionary = d.map.dictionary;
  ips::Detector detector(options);
  ips::JpegDecoder decoder;
  cv::Mat gray;
  std::size_t i = 0, placed = 0, markers = 0;
  for (auto _ : state) {
    decoder.decode_gray(d.jpegs[i++ % d.jpegs.size()], gray);
    const auto found = detector.detect(gray, &d.lens);
    const ips::Localisation l = ips::localise(found, d.lens, d.map, ips::CameraMount{});
    placed += l.ok;
    markers += l.used.size();
    benchmark::DoNotOptimize(l);
  }
  state.counters["placed_%"] = 100.0 * static_cast<double>(placed) / static_cast<double>(state.iterations());
  state.counters["markers"] = static_cast<double>(markers) / static_cast<double>(state.iterations());
}

void detect(benchmark::State& state) {
  const Drive& d = drive();
  ips::DetectorOptions options;
  options.dictionary = d.map.dictionary;
  ips::Detector detector(options);
  std::size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(detector.detect(d.frames[i++ % d.frames.size()], &d.lens));
}

void localise(benchmark::State& state) {
  const Drive& d = drive();
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(ips::localise(d.detections[i++ % d.detections.size()], d.lens, d.map, ips::CameraMount{}));
  }
}

}  // namespace

BENCHMARK(full)->Unit(benchmark::kMillisecond);
BENCHMARK(detect)->Unit(benchmark::kMillisecond);
BENCHMARK(localise)->Unit(benchmark::kMicrosecond);
BENCHMARK_MAIN();
