// docs/configuration.md is the list of configuration keys: every key the parsers accept has a row
// there, and every row names a key they accept. The accepted keys are recorded from the parsers
// themselves (ips/core/accepted_keys.h) while they read a configuration that has every section, every
// camera source, every output type and every kind of body.
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "config_scratch.h"
#include "ips/core/accepted_keys.h"

namespace ips {
namespace {

/// "cameras[2].controls.gain" -> "cameras[].controls.gain"; "markers.ids.7.name" ->
/// "markers.ids.<id>.name": the documentation's form of a key path.
std::string documented_form(const std::string& path) {
  std::string p = std::regex_replace(path, std::regex(R"(\[[0-9]+\])"), "[]");
  return std::regex_replace(p, std::regex(R"(^markers\.ids\.[0-9]+)"), "markers.ids.<id>");
}

/// The key paths of docs/configuration.md: the first cell of every table row that is exactly one
/// backticked key path.
std::set<std::string> documented_keys(const std::filesystem::path& page) {
  std::ifstream in(page);
  std::set<std::string> keys;
  const std::regex row(R"(^\|\s*`([A-Za-z_<>\[\]\.0-9]+)`\s*\|)");
  std::string line;
  std::smatch m;
  while (std::getline(in, line))
    if (std::regex_search(line, m, row)) keys.insert(m[1]);
  return keys;
}

class DocumentedKeys : public test::ConfigScratch {};

TEST_F(DocumentedKeys, EveryAcceptedKeyIsDocumentedAndEveryDocumentedKeyIsAccepted) {
  const std::string text = R"(
cameras:
  - name: left
    model: red
    source: v4l2
    device: /dev/video0
    width: 1280
    height: 720
    pixel_format: YUYV
    buffer_count: 4
    controls: {auto_exposure: false, exposure: 0.004, gain: 20, autofocus: false, power_line_hz: 50}
    fps: 15
    intrinsics: red.yaml
    timestamp_offset: 0.001
    required: true
  - {name: replay, model: red, source: file, path: ., loop: false, preload: false, intrinsics: red.yaml}
  - {name: sim, model: red, source: synthetic, scene: scene.yaml, scene_camera: white, phase: 0.01,
     transport_delay: 0.02, intrinsics: red.yaml}
  - name: robot
    source: synthetic
    scene: scene.yaml
    on_robot: {marker: 3, map: map.json, offset: [0, 0, 0.3], yaw_deg: 0, roll_deg: 0, pitch_deg: 0,
               pixel_sigma: 0.5, outlier_px: 3, tilt_sigma_deg: 1, map_sigma: 0.01}
markers:
  dictionary: DICT_4X4_100
  edge_length: 0.15
  height: 0.1
  ids:
    3: {name: robot3, edge_length: 0.1, height: 0.2, publish: true}
    9: {fixed: [1.0, 2.0, 0.0]}
detection:
  min_marker_px: 20
  detect_scale: 2
  threshold_windows: [9]
  threshold_constant: 7
  max_perimeter_rate: 4
  error_correction_rate: 0.6
  max_border_error_rate: 0.35
  max_ambiguous_cells: 2
  cell_ambiguity: 0.2
  min_clear_margin: 2
  min_contrast: 25
  refinement: edges
  refine_half_window_px: 4
  tracking: true
  full_search_period: 6
  roi_margin: 0.5
bodies:
  - {name: cube, ground: false, edge: 0.08, cube: {id: 20, edge: 0.08, size: 0.1, height: 0.0}}
  - name: pair
    flat: [{id: 21, offset: [0.2, 0], edge: 0.1, yaw_deg: 0}, {id: 22, offset: [-0.2, 0], edge: 0.1}]
  - name: free
    markers: [{id: 23, edge: 0.1, plate: 0.12, position: [0, 0, 0.3], normal: [0, 0, 1], roll_deg: 0}]
model_file: model.json
fusion:
  method: mean
  window: 0.05
  velocity_span: 0.2
  history: 0.25
  single_camera_depth: false
  output_rate: 0
  fixed_marker_warn: 0.03
  camera_sigma: 0.002
  out_of_view_process_noise: 0.1
  camera_hold: 0.5
  max_wait: 0.05
  kalman: {enabled: true, process_noise: 0.5, measurement_noise: 0.0001, reset_after: 0.5, initial_velocity_std: 1.0}
outputs:
  - {type: unicast, address: 127.0.0.1, port: 5005, format: binary}
  - {type: multicast, address: 239.1.2.3, port: 5006, format: json, ttl: 1, interface: 127.0.0.1}
  - type: mavlink
    address: 127.0.0.1
    port: 14550
    vehicles: [{marker: 3, system_id: 1, address: 127.0.0.1, port: 14551, marker_yaw_deg: 0}]
    messages: [vision_position_estimate]
    component_id: 197
    yaw_offset_deg: 0
    track_gap: 0.5
    heartbeat: true
  - {type: subscriptions, address: 127.0.0.1, port: 5007, allow: [127.0.0.1/32], max_subscribers: 4, max_lease: 60}
  - {type: ros2, domain: 0, prefix: ipsd, pose: true, odometry: true, tf: true, depth: 1}
logging: {level: info}
status: {interval: 10, socket: ""}
processing: {workers: 2, budget: 0.033}
watchdog: {stall_timeout: 2}
web: {listen: "127.0.0.1:8080", floor: [0, 0, 4, 4]}
ranging:
  address: 0.0.0.0
  port: 5800
  allow: [10.0.0.0/8]
  psk: secret
  rate_per_source: 100
  reorder_window: 0.3
  max_clock_ahead: 1
  method: robust
  height: 0.1
  sigma: 0.05
  ultrasound: {temperature: 21.5, assumed_speed: 343}
  track: {process_noise: 0.3, gate: 4, learn_bias: true, bias_sigma: 0.03, reorder_window: 0.5, camera_reference: true,
          mutual: true}
  anchors:
    - {id: 1, x: 0, y: 0, z: 2.5, bias: 0.02, scale: 1.0, sigma: 0.04}
    - {id: 2, x: 4, y: 0, z: 2.5}
    - {id: 3, x: 4, y: 3, z: 2.5}
  tags:
    - {id: 7, marker: 3, height: 0.1}
    - {id: 8, body: pair, offset: [0, 0, 0.3]}
)";
  std::set<std::string> recorded;
  {
    const AcceptedKeysRecording recording(recorded);
    std::ofstream(dir_ / "map.json") << "{}";  // on_robot.map must exist (its content is read by ipsd)
    (void)parse_text(text);
    // The older form of min_marker_px, which may not stand beside it.
    (void)parse_text(test::kSyntheticRedConfig + "detection: {min_perimeter_px: 80}\n");
    // z_range, which may not stand beside height.
    (void)parse_text(
        test::kSyntheticRedConfig +
        "ranging: {port: 5801, z_range: [0, 2], anchors: [{id: 1, x: 0, y: 0, z: 2}, {id: 2, x: 4, "
        "y: 0, z: 1}, {id: 3, x: 4, y: 3, z: 2}, {id: 4, x: 0, y: 3, z: 1}], tags: [{id: 7, marker: 5}]}\n");
  }
  std::set<std::string> accepted;
  for (const auto& k : recorded) accepted.insert(documented_form(k));
  // Sanity: the recording saw every section (a parser that stopped noting keys fails here, not
  // as a hundred "undocumented" lines).
  for (const char* k : {"cameras[].controls.gain", "cameras[].on_robot.map_sigma", "markers.ids.<id>.fixed",
                        "bodies[].flat[].yaw_deg", "outputs[].vehicles[].system_id", "fusion.kalman.reset_after",
                        "web.floor", "ranging.anchors[].bias", "ranging.z_range"})
    EXPECT_TRUE(accepted.count(k)) << k << " was not recorded";

  const auto page = std::filesystem::path(IPS_SOURCE_DIR) / "docs" / "configuration.md";
  ASSERT_TRUE(std::filesystem::exists(page)) << page;
  const std::set<std::string> documented = documented_keys(page);
  for (const auto& k : accepted)
    EXPECT_TRUE(documented.count(k)) << "accepted but not documented in docs/configuration.md: " << k;
  for (const auto& k : documented)
    EXPECT_TRUE(accepted.count(k)) << "documented in docs/configuration.md but not accepted: " << k;
}

}  // namespace
}  // namespace ips
