// ipsd's reload keeps the camera threads running when `cameras` did not change
// (Daemon::reload compares the parsed CameraConfig with ==). The soak (tools/bench_soak)
// found that a field defaulting to NaN made == false for every camera, so each SIGHUP
// restarted every camera. These tests parse the same text twice and compare.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "config_scratch.h"
#include "ips/config/config.h"

namespace ips {
namespace {

namespace fs = std::filesystem;

class ReloadEquality : public test::ConfigScratch {
 protected:
  DaemonConfig parse(const std::string& text) { return parse_text(text); }
};

std::string config(const std::string& cameras, double window) {
  return "cameras:\n" + cameras + "model_file: model.json\nfusion: {window: " + std::to_string(window) + "}\n";
}

TEST_F(ReloadEquality, UnchangedCamerasCompareEqualForEverySourceKind) {
  const std::string cams =
      "  - {name: red, source: v4l2, device: /dev/video0, intrinsics: red.yaml, controls: {exposure: 0.004}}\n"
      "  - {name: white, source: file, path: " +
      dir_.string() +
      ", intrinsics: red.yaml}\n"
      "  - {name: black, source: synthetic, scene: scene.yaml}\n"
      "  - {name: blue, source: synthetic, scene: scene.yaml, transport_delay: 0.02}\n";
  const DaemonConfig a = parse(config(cams, 0.02));
  const DaemonConfig b = parse(config(cams, 0.025));  // only the fusion changed
  ASSERT_EQ(a.cameras.size(), 4u);
  for (std::size_t i = 0; i < a.cameras.size(); ++i) EXPECT_TRUE(a.cameras[i] == b.cameras[i]) << a.cameras[i].name;
  EXPECT_TRUE(a.cameras == b.cameras);
  EXPECT_FALSE(a.cameras[2].transport_delay_s.has_value());  // unset: one frame period
  ASSERT_TRUE(a.cameras[3].transport_delay_s.has_value());
  EXPECT_DOUBLE_EQ(*a.cameras[3].transport_delay_s, 0.02);
}

TEST_F(ReloadEquality, AChangedCameraSettingComparesUnequal) {
  const auto with = [&](const std::string& exposure, const std::string& delay) {
    return parse(config(
        "  - {name: red, source: v4l2, device: /dev/video0, intrinsics: red.yaml, controls: {exposure: " + exposure +
            "}}\n  - {name: black, source: synthetic, scene: scene.yaml" + delay + "}\n",
        0.02));
  };
  const DaemonConfig base = with("0.004", "");
  EXPECT_FALSE(base.cameras == with("0.005", "").cameras);
  EXPECT_FALSE(base.cameras == with("0.004", ", transport_delay: 0.03").cameras);
}

TEST_F(ReloadEquality, TransportDelayAboveOneSecondIsRefusedNamingTheKey) {
  try {
    (void)parse(config("  - {name: black, source: synthetic, scene: scene.yaml, transport_delay: 1.5}\n", 0.02));
    ADD_FAILURE() << "accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("transport_delay"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("<= 1 second"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ips
