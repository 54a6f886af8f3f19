#include "ips/config/config.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "config_scratch.h"
#include "ips/core/error.h"

namespace ips {
namespace {

namespace fs = std::filesystem;

class ConfigTest : public test::ConfigScratch {
 protected:
  DaemonConfig parse(const std::string& text) { return parse_text(text); }
  void expect_error(const std::string& text, std::initializer_list<std::string> fragments) {
    expect_refused(text, fragments);
  }
};

const char* kMinimal = R"(cameras:
  - name: red
    source: v4l2
    device: /dev/video0
    intrinsics: red.yaml
model_file: model.json
)";

TEST_F(ConfigTest, MinimalConfigGetsTheDocumentedDefaults) {
  const DaemonConfig c = parse(kMinimal);
  ASSERT_EQ(c.cameras.size(), 1u);
  const CameraConfig& cam = c.cameras[0];
  EXPECT_EQ(cam.index, 0);
  EXPECT_EQ(cam.name, "red");
  EXPECT_EQ(cam.model, "red");
  EXPECT_EQ(cam.source, SourceKind::kV4l2);
  EXPECT_EQ(cam.v4l2.device, "/dev/video0");
  EXPECT_EQ(cam.v4l2.width, 1920);
  EXPECT_EQ(cam.v4l2.height, 1080);
  EXPECT_EQ(cam.v4l2.format, PixelFormat::kMjpeg);
  EXPECT_FALSE(cam.v4l2.controls.exposure_s.has_value());
  EXPECT_DOUBLE_EQ(cam.fps, 30.0);
  EXPECT_FALSE(cam.required);
  EXPECT_EQ(cam.intrinsics, dir_ / "red.yaml");
  EXPECT_EQ(c.model_file, dir_ / "model.json");
  EXPECT_EQ(c.markers.dictionary, "DICT_4X4_100");
  EXPECT_DOUBLE_EQ(c.markers.edge_length, 0.20);
  EXPECT_TRUE(std::isnan(c.markers.height_of(3)));
  EXPECT_EQ(c.fusion.method, "mean");
  EXPECT_DOUBLE_EQ(c.fusion.window_s, 0.050);
  EXPECT_DOUBLE_EQ(c.fusion.history_s, 0.250);
  EXPECT_DOUBLE_EQ(c.fusion.output_rate_hz, 0.0);
  EXPECT_FALSE(c.fusion.single_camera_depth);
  EXPECT_DOUBLE_EQ(cam.timestamp_offset_s, 0.0);
  EXPECT_FALSE(c.fusion.kalman);
  EXPECT_TRUE(c.outputs.empty());
  EXPECT_EQ(c.log_level, "info");
  EXPECT_DOUBLE_EQ(c.status.interval_s, 10.0);
  EXPECT_EQ(c.status.socket, "");
  EXPECT_EQ(c.detection, DetectorOptions{});  // the library's defaults, documented in detector.h
}

TEST_F(ConfigTest, DetectionSectionTunesTheDetector) {
  const DaemonConfig c = parse(std::string(kMinimal) + R"(markers: {dictionary: DICT_5X5_100}
detection:
  detect_scale: 1
  threshold_windows: [9, 19]
  threshold_constant: 10
  min_perimeter_px: 80
  max_perimeter_rate: 2
  error_correction_rate: 0.3
  max_border_error_rate: 0.2
  max_ambiguous_cells: -1
  cell_ambiguity: 0.25
  min_clear_margin: 4
  min_contrast: 40
  refinement: subpix
  refine_half_window_px: 3
)");
  const DetectorOptions& d = c.detection;
  EXPECT_EQ(d.dictionary, "DICT_5X5_100");  // from markers.dictionary
  EXPECT_EQ(d.detect_scale, 1);
  EXPECT_EQ(d.threshold_windows, (std::vector<int>{9, 19}));
  EXPECT_DOUBLE_EQ(d.threshold_constant, 10);
  EXPECT_DOUBLE_EQ(d.min_marker_px, 20);  // min_perimeter_px, the older form: 4 sides
  EXPECT_DOUBLE_EQ(d.max_perimeter_rate, 2);
  EXPECT_DOUBLE_EQ(d.error_correction_rate, 0.3);
  EXPECT_DOUBLE_EQ(d.max_border_error_rate, 0.2);
  EXPECT_EQ(d.max_ambiguous_cells, -1);
  EXPECT_DOUBLE_EQ(d.cell_ambiguity, 0.25);
  EXPECT_EQ(d.min_clear_margin, 4);
  EXPECT_DOUBLE_EQ(d.min_contrast, 40);
  EXPECT_EQ(d.refinement, CornerRefinement::kSubPix);
  EXPECT_EQ(d.refine_half_window_px, 3);
  EXPECT_NO_THROW(Detector{d});
}

TEST_F(ConfigTest, DetectionTrackingKeys) {
  EXPECT_EQ(parse(kMinimal).tracking, TrackerOptions{});  // on, full search every 6 frames
  EXPECT_TRUE(TrackerOptions{}.enabled);
  const DaemonConfig c =
      parse(std::string(kMinimal) + "detection: {tracking: false, full_search_period: 3, roi_margin: 1.5}\n");
  EXPECT_FALSE(c.tracking.enabled);
  EXPECT_EQ(c.tracking.full_search_period, 3);
  EXPECT_DOUBLE_EQ(c.tracking.roi_margin, 1.5);
  const std::string m = kMinimal;
  expect_error(m + "detection: {tracking: maybe}\n", {"ipsd.yaml:7:", "detection.tracking: expected true or false"});
  expect_error(m + "detection: {full_search_period: 0}\n", {"detection.full_search_period: must be 1..1000"});
  expect_error(m + "detection: {roi_margin: 0.1}\n", {"detection.roi_margin: must be 0.25..100"});
}

TEST_F(ConfigTest, BadDetectionSettingsAndDictionaryNamesAreRefusedWithTheirPlace) {
  const std::string m = kMinimal;
  expect_error(m + "markers: {dictionary: DICT_4x4_100}\n",
               {"ipsd.yaml:7:23: markers.dictionary: unknown ArUco dictionary 'DICT_4x4_100'", "DICT_4X4_100"});
  expect_error(m + "detection: {threshold_windows: [9, 10]}\n",
               {"ipsd.yaml:7:", "detection.threshold_windows[1]: window sizes must be odd"});
  expect_error(m + "detection: {threshold_windows: []}\n", {"detection.threshold_windows: expected a non-empty list"});
  expect_error(m + "detection: {threshold_windows: 9}\n", {"detection.threshold_windows: expected a non-empty list"});
  expect_error(m + "detection: {detect_scale: 9}\n", {"detection.detect_scale: must be 0..8"});
  expect_error(m + "detection: {min_marker_px: -1}\n", {"ipsd.yaml:7:", "detection.min_marker_px: must be 0..100000"});
  expect_error(m + "detection: {min_marker_px: 20, min_perimeter_px: 80}\n",
               {"detection.min_perimeter_px: give min_marker_px only"});
  expect_error(m + "detection: {min_clear_margin: 0}\n", {"detection.min_clear_margin: must be 1..64"});
  expect_error(m + "detection: {refinement: cornersubpix}\n",
               {"detection.refinement: unknown value 'cornersubpix' (edges|subpix|none)"});
  expect_error(m + "detection: {min_perimeter_px: -5}\n", {"detection.min_perimeter_px: must be > 0"});
  expect_error(m + "detection: {error_correction_rate: 1.5}\n", {"detection.error_correction_rate: must be 0..1"});
  expect_error(m + "detection: {min_contrast: lots}\n", {"detection.min_contrast: expected a number, got 'lots'"});
  expect_error(m + "detection: {threshold_window: [9]}\n", {"detection.threshold_window: unknown key"});
}

TEST_F(ConfigTest, FullConfigIsReadKeyByKey) {
  const DaemonConfig c = parse(R"(cameras:
  - name: left
    model: red
    source: v4l2
    device: /dev/v4l/by-id/usb-cam-video-index0
    width: 1280
    height: 720
    pixel_format: YUYV
    fps: 15
    controls: {auto_exposure: false, exposure: 0.004, gain: 20, autofocus: false, power_line_hz: 50}
    intrinsics: red.yaml
    required: true
  - name: sim
    source: synthetic
    scene: scene.yaml
    scene_camera: white
    intrinsics: red.yaml
markers:
  dictionary: DICT_5X5_50
  edge_length: 0.15
  height: 0.1
  ids:
    3: {name: robot3, edge_length: 0.1}
    7: {height: 0.25}
model_file: model.json
fusion:
  method: gauss
  window: 0.01
  max_wait: 0.04
  velocity_span: 0.1
  history: 0.5
  single_camera_depth: true
  output_rate: 100
  camera_sigma: 0.004
  out_of_view_process_noise: 0.5
  kalman: {enabled: true, process_noise: 2.0, measurement_noise: 0.0004, reset_after: 1.0}
outputs:
  - {type: multicast, address: 239.1.2.3, port: 5005, format: json, ttl: 2, interface: 10.0.0.5}
  - {type: unicast, address: 127.0.0.1, port: 6000}
logging: {level: debug}
status: {interval: 2.5, socket: /run/ipsd/status.sock}
watchdog: {stall_timeout: 3}
)");
  ASSERT_EQ(c.cameras.size(), 2u);
  const auto& left = c.cameras[0];
  EXPECT_EQ(left.model, "red");
  EXPECT_EQ(left.v4l2.width, 1280);
  EXPECT_EQ(left.v4l2.format, PixelFormat::kYuyv);
  EXPECT_DOUBLE_EQ(left.fps, 15.0);
  EXPECT_EQ(left.v4l2.controls.auto_exposure, false);
  EXPECT_DOUBLE_EQ(left.v4l2.controls.exposure_s.value(), 0.004);
  EXPECT_EQ(left.v4l2.controls.gain, 20);
  EXPECT_EQ(left.v4l2.controls.power_line_hz, 50);
  EXPECT_TRUE(left.required);
  const auto& sim = c.cameras[1];
  EXPECT_EQ(sim.index, 1);
  EXPECT_EQ(sim.source, SourceKind::kSynthetic);
  EXPECT_EQ(sim.scene, dir_ / "scene.yaml");
  EXPECT_EQ(sim.scene_camera, "white");
  EXPECT_EQ(c.markers.dictionary, "DICT_5X5_50");
  EXPECT_DOUBLE_EQ(c.markers.sizes().length_of(3), 0.1);
  EXPECT_DOUBLE_EQ(c.markers.sizes().length_of(4), 0.15);
  EXPECT_DOUBLE_EQ(c.markers.height_of(7), 0.25);
  EXPECT_DOUBLE_EQ(c.markers.height_of(3), 0.1);
  EXPECT_EQ(c.markers.ids.at(3).name, "robot3");
  EXPECT_EQ(c.fusion.method, "gauss");
  EXPECT_TRUE(c.fusion.kalman);
  EXPECT_DOUBLE_EQ(c.fusion.kalman_options.process_noise, 2.0);
  EXPECT_DOUBLE_EQ(c.fusion.velocity_span_s, 0.1);
  EXPECT_DOUBLE_EQ(c.fusion.history_s, 0.5);
  EXPECT_TRUE(c.fusion.single_camera_depth);
  EXPECT_DOUBLE_EQ(c.fusion.output_rate_hz, 100.0);
  EXPECT_DOUBLE_EQ(c.fusion.camera_sigma_m, 0.004);
  EXPECT_DOUBLE_EQ(c.fusion.between_cameras_process_noise, 0.5);
  ASSERT_EQ(c.outputs.size(), 2u);
  EXPECT_EQ(c.outputs[0].kind, OutputConfig::Kind::kMulticast);
  EXPECT_EQ(c.outputs[0].format, WireFormat::kJson);
  EXPECT_EQ(c.outputs[0].ttl, 2);
  EXPECT_EQ(c.outputs[0].interface, "10.0.0.5");
  EXPECT_EQ(c.outputs[1].format, WireFormat::kBinary);
  EXPECT_EQ(c.outputs[1].describe(), "unicast 127.0.0.1:6000 (binary)");
  EXPECT_EQ(c.log_level, "debug");
  EXPECT_DOUBLE_EQ(c.status.interval_s, 2.5);
  EXPECT_DOUBLE_EQ(c.stall_timeout_s, 3.0);
}

// `ips collect` reads the configuration before `ips fit` has written the model file.
TEST_F(ConfigTest, ModelFileMayBeMissingForCollect) {
  const std::string m = kMinimal;
  const std::string text = std::string(kMinimal).replace(m.find("model.json"), 10, "later.json");
  const DaemonConfig c =
      parse_config(text, dir_ / "ipsd.yaml", ConfigChecks{.intrinsics_exist = true, .model_file_exists = false});
  EXPECT_EQ(c.model_file, dir_ / "later.json");
  expect_error(text, {"model_file: no such file"});  // the daemon still needs it
  const std::string empty = std::string(kMinimal).replace(m.find("model.json"), 10, "\"\"");
  EXPECT_THROW(
      parse_config(empty, dir_ / "ipsd.yaml", ConfigChecks{.intrinsics_exist = true, .model_file_exists = false}),
      InputError);
}

TEST_F(ConfigTest, EveryMalformedCaseNamesTheKeyAndThePlace) {
  std::string m = kMinimal;
  expect_error(m + "colour: red\n", {"ipsd.yaml:7:1: colour: unknown key"});
  expect_error(std::string(kMinimal).replace(m.find("    intrinsics"), 0, "    fsp: 30\n"),
               {"ipsd.yaml:5:5: cameras[0].fsp: unknown key"});
  expect_error(m + "fusion: {method: average}\n", {"fusion.method: unknown method 'average' (mean|area|gauss|median)"});
  expect_error(m + "fusion: {window: soon}\n", {"fusion.window: expected a number, got 'soon'"});
  expect_error(m + "fusion: {max_wait: -1}\n", {"fusion.max_wait: must be > 0"});
  expect_error(m + "fusion: {camera_sigma: 0}\n", {"fusion.camera_sigma: must be > 0"});
  expect_error(m + "fusion: {out_of_view_process_noise: -0.1}\n", {"fusion.out_of_view_process_noise: must be > 0"});
  expect_error(m + "fusion: {window: 0.3}\n", {"fusion.history: must be >= fusion.window"});
  expect_error(m + "fusion: {output_rate: 5000}\n", {"fusion.output_rate: must be <= 1000 Hz"});
  expect_error(std::string(kMinimal).replace(m.find("    intrinsics"), 0, "    timestamp_offset: 2\n"),
               {"cameras[0].timestamp_offset: must be within [-1, 1] seconds"});
  expect_error(m + "outputs:\n  - {type: unicast, address: 127.0.0.1, port: 70000}\n",
               {"outputs[0].port: must be 1..65535"});
  expect_error(m + "outputs:\n  - {type: anycast, address: 127.0.0.1, port: 7}\n",
               {"outputs[0].type: unknown value 'anycast'"});
  expect_error(m + "outputs:\n  - {type: unicast, port: 7}\n", {"outputs[0].address: required key is missing"});
  expect_error(m + "outputs:\n  - {type: unicast, address: 127.0.0.1, port: 7, format: xml}\n",
               {"outputs[0].format: unknown value 'xml'"});
  expect_error(m + "logging: {level: loud}\n", {"logging.level: unknown value 'loud'"});
  expect_error(m + "markers: {ids: {x1: {height: 0.1}}}\n", {"markers.ids.x1: marker id must be"});
  // A list or mapping as a key (found by fuzz_scene; yaml-cpp's own exception escaped before).
  expect_error(m + "? [fusion]\n: {window: 1}\n", {"ipsd.yaml:7:", "the document: a key must be a plain word"});
  expect_error(m + "markers: {ids: {? [3]: {height: 0.1}}}\n", {"markers.ids: marker id must be"});
  expect_error(m + "markers: {edge_length: 0}\n", {"markers.edge_length: must be > 0"});
  expect_error(std::string(kMinimal).replace(m.find("red.yaml"), 8, "nothere.yaml"),
               {"cameras[0].intrinsics: no such file", "nothere.yaml"});
  expect_error(std::string(kMinimal).replace(m.find("model.json"), 10, "missing.json"), {"model_file: no such file"});
  expect_error(std::string(kMinimal).replace(m.find("v4l2"), 4, "webcam"),
               {"cameras[0].source: unknown value 'webcam' (v4l2|file|synthetic)"});
  expect_error(std::string(kMinimal).replace(m.find("    device: /dev/video0\n"), 24, ""),
               {"cameras[0].device: required key is missing"});
  expect_error(m + "cameras: []\n", {"ipsd.yaml:7:1: cameras: duplicate key"});
  expect_error("model_file: model.json\n", {"cameras: required"});
  expect_error(
      "cameras:\n  - {name: a, source: v4l2, device: /dev/video0, intrinsics: red.yaml, fps: fast}\nmodel_file: "
      "model.json\n",
      {"ipsd.yaml:2:", "cameras[0].fps: expected a number, got 'fast'"});
  expect_error(
      "cameras:\n  - {name: a, source: v4l2, device: /dev/video0, intrinsics: red.yaml, required: maybe}\nmodel_file: "
      "model.json\n",
      {"cameras[0].required: expected true or false"});
  expect_error(
      "cameras:\n  - {name: a, source: v4l2, device: /dev/video0, intrinsics: red.yaml}\n"
      "  - {name: a, source: v4l2, device: /dev/video1, intrinsics: red.yaml}\nmodel_file: model.json\n",
      {"cameras[1].name: duplicate camera name 'a'"});
  expect_error("cameras: [\nmodel_file", {"ipsd.yaml:", "not valid YAML"});
  expect_error("", {"empty configuration"});
  expect_error(
      "cameras:\n  - {name: a, source: v4l2, device: /dev/video0, intrinsics: red.yaml, controls: {exposure: "
      "150}}\nmodel_file: model.json\n",
      {"cameras[0].controls.exposure: must be in (0, 1] seconds"});
  expect_error(
      "cameras:\n  - {name: a, source: v4l2, device: /dev/video0, intrinsics: red.yaml, controls: {power_line_hz: "
      "55}}\nmodel_file: model.json\n",
      {"cameras[0].controls.power_line_hz: must be 50, 60 or 0"});
  expect_error(
      "cameras:\n  - {name: a, source: v4l2, device: /dev/video0, intrinsics: red.yaml, controls: {brightness: "
      "3}}\nmodel_file: model.json\n",
      {"cameras[0].controls.brightness: unknown key"});
}

TEST_F(ConfigTest, LoadReadsTheFileAndRefusesAMissingOne) {
  std::ofstream(dir_ / "ipsd.yaml") << kMinimal;
  EXPECT_EQ(load_config(dir_ / "ipsd.yaml").cameras.at(0).name, "red");
  EXPECT_THROW((void)load_config(dir_ / "nope.yaml"), InputError);
}

TEST_F(ConfigTest, ShippedExampleConfigsParse) {
  for (const char* name : {"ipsd.yaml", "demo.yaml"}) {
    const fs::path p = fs::path(IPS_CONFIG_DIR) / name;
    if (!fs::exists(p)) continue;  // demo.yaml's model is generated by tools/demo.sh
    SCOPED_TRACE(name);
    try {
      const DaemonConfig c = load_config(p);
      EXPECT_GE(c.cameras.size(), 3u);
    } catch (const InputError& e) {
      // The lab example points at /dev/v4l and /etc paths that need not exist here; only a
      // missing-file complaint is acceptable.
      EXPECT_NE(std::string(e.what()).find("no such file"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace ips
