// `ips collect` on a V4L2 camera (the emulated device of tests/capture): the same pairs as
// from the simulator's truth, through the daemon's V4L2 source, MJPEG decoding and detector.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "emu_control.h"
#include "emu_harness.h"
#include "ips/mapping/calib_data.h"
#include "ips/sim/renderer.h"
#include "ips/sim/scene.h"
#include "published_scene.h"

namespace {

namespace fs = std::filesystem;

TEST(CollectOnV4l2, RecordsThePairOfAStaticMarker) {
  ips::test::TempDir dir;
  std::ofstream(dir / "scene.yaml") << ips::test::published_scene_with(
      "markers:\n  - {id: 0, length: 0.20, x: 2.2, y: 1.55, height: 0.15, yaw_deg: 20}\n");
  const auto scene = ips::sim::Scene::load(dir / "scene.yaml");
  const ips::sim::CameraRenderer renderer(scene, scene.camera_index("red"));
  fs::create_directories(dir / "frames");
  cv::Mat gray;
  for (int k = 0; k < 3; ++k) {  // the camera's MJPEG stream: colour JPEG, grey chroma
    renderer.render(0.0, gray, static_cast<std::uint64_t>(k));
    const auto jpeg = ips::sim::encode_jpeg(gray, 90, true);
    std::ofstream(dir / ("frames/f" + std::to_string(k) + ".jpg"), std::ios::binary)
        .write(reinterpret_cast<const char*>(jpeg.data()), static_cast<std::streamsize>(jpeg.size()));
  }
  const auto truth = renderer.truth(0.0).at(0);
  ASSERT_TRUE(truth.visible);
  ips::test::write_emu_control(dir / "red.conf", {{"formats", "MJPG"},
                                                  {"sizes", "1920x1080"},
                                                  {"fps", "10"},
                                                  {"frames", dir / "frames"},
                                                  {"card", "Emulated red"}});
  std::ofstream(dir / "ipsd.yaml") << "cameras:\n  - {name: red, source: v4l2, device: /dev/video-emu0, fps: 10, "
                                      "intrinsics: "
                                   << IPS_TEST_DATA_DIR << "/ou2023/intrinsics_red.yaml}\nmodel_file: model.json\n";
  std::ofstream(dir / "typed.txt") << "2,2 1.55\n2.2 1.55 0.15\n";
  const auto r =
      ips::test::run_emulated({"/bin/sh", "-c",
                               std::string(IPS_TOOL) + " collect --config " + (dir / "ipsd.yaml") +
                                   " --marker 0 --frames 5 --out " + (dir / "pairs.csv") + " < " + (dir / "typed.txt")},
                              {{"/dev/video-emu0", dir / "red.conf"}}, dir.str());
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("not understood: use spaces between the numbers"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("red        seen in  5/5  frames"), std::string::npos) << r.out;
  const ips::CalibData data = ips::load_calib_csv(dir / "pairs.csv");
  ASSERT_EQ(data.cameras.size(), 1u);
  ASSERT_EQ(data.cameras[0].cam.size(), 1u);
  EXPECT_EQ(data.cameras[0].world[0], Eigen::Vector3d(2.2, 1.55, 0.15));
  // What a perfect detector reports for these frames (the depth formula on the exact corners).
  EXPECT_LT((data.cameras[0].cam[0] - truth.formula.p_cam).norm(), 0.01)
      << data.cameras[0].cam[0].transpose() << " vs " << truth.formula.p_cam.transpose();
}

}  // namespace
