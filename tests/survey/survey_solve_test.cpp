// The survey's chain without rendering: detections made by projecting the simulated lab's
// marker corners through each camera's true pose and lens (plus 0.15 px noise), at each
// camera's own frame times (unsynchronised), written as an `ips record` session, then read
// back, still periods found, bundle-adjusted. Truth: the scene's camera poses.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "ips/core/error.h"
#include "ips/mapping/model_file.h"
#include "ips/sim/scene.h"
#include "ips/survey/survey.h"
#include "process_util.h"
#include "survey_lab.h"

namespace ips {
namespace {

namespace fs = std::filesystem;

struct Lab {
  fs::path dir;
  sim::Scene scene;
};

// Writes the lab scene and a session of `seconds` of detections at `fps`; returns the scene.
Lab make_session(const std::string& tag, double seconds, double fps, double noise_px,
                 const std::vector<int>& skip_ids = {}) {
  Lab lab;
  lab.dir = fs::temp_directory_path() / ("ips_survey_solve_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(lab.dir);
  fs::create_directories(lab.dir / "session");
  std::ofstream(lab.dir / "lab.yaml") << test::lab_scene(IPS_TEST_DATA_DIR, 1.0, 1.0);
  lab.scene = sim::Scene::load(lab.dir / "lab.yaml");
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, noise_px);
  survey::Session session;
  session.config = "lab-config";
  std::vector<std::pair<std::string, CameraModel>> models;
  for (std::size_t c = 0; c < lab.scene.cameras.size(); ++c) {
    const sim::SceneCamera& cam = lab.scene.cameras[c];
    models.emplace_back(cam.name, cam.model);
    session.cameras.push_back({cam.name, cam.name + ".det", {}});
    std::ofstream out(lab.dir / "session" / (cam.name + ".det"));
    const double phase = test::lab_cameras()[c].phase_s;
    for (int k = 0; phase + k / fps < seconds; ++k) {
      const double t = phase + k / fps;
      for (std::size_t m = 0; m < lab.scene.markers.size(); ++m) {
        const auto& marker = lab.scene.markers[m];
        if (std::find(skip_ids.begin(), skip_ids.end(), marker.id) != skip_ids.end()) continue;
        const sim::MarkerPose pose = lab.scene.marker_pose_at(m, t);
        const double h = marker.length / 2, cs = std::cos(pose.yaw), sn = std::sin(pose.yaw);
        // TL, TR, BR, BL as printed: marker x right, y up, seen from above.
        const double corner[4][2] = {{-h, h}, {h, h}, {h, -h}, {-h, -h}};
        survey::Detection d;
        d.t_ns = std::llround(t * 1e9);
        d.id = marker.id;
        bool inside = true;
        for (int i = 0; i < 4; ++i) {
          const Eigen::Vector3d w(pose.x + cs * corner[i][0] - sn * corner[i][1],
                                  pose.y + sn * corner[i][0] + cs * corner[i][1], pose.z);
          const Eigen::Vector3d pc = cam.world_to_camera(w);
          const Point2 px = cam.model.project({pc.x() / pc.z(), pc.y() / pc.z()});
          inside = inside && pc.z() > 0 && px.x > 20 && px.y > 20 && px.x < cam.model.size().width - 20 &&
                   px.y < cam.model.size().height - 20;
          d.corners[static_cast<std::size_t>(i)] = {px.x + noise(rng), px.y + noise(rng)};
        }
        if (inside) out << survey::detection_line(d) << "\n";
      }
    }
  }
  session.fingerprint = survey::camera_fingerprint(models);
  session.dictionary = "DICT_4X4_100";
  session.seconds = seconds;
  std::ofstream(lab.dir / "session" / "session.txt") << survey::session_header(session);
  return lab;
}

survey::SurveyInput make_input(const Lab& lab, const survey::Session& session) {
  survey::SurveyInput input;
  for (const auto& c : lab.scene.cameras) input.cameras.push_back({c.name, c.name, c.model});
  input.instants = survey::group_instants(survey::find_still_periods(session, {}), 0.1);
  for (const auto& r : test::lab_references()) input.references.push_back({r.id, {r.x, r.y, 0.0}, std::nullopt});
  for (const auto& m : lab.scene.markers) input.edge_length[m.id] = m.length;
  return input;
}

TEST(SurveySolve, UnsynchronisedCamerasStillPeriodsGiveThePosesWithinMillimetres) {
  const Lab lab = make_session("ok", 61.0, 15.0, 0.15);  // two loops of the wand path
  const survey::Session session = survey::load_session(lab.dir / "session");
  ASSERT_EQ(session.cameras.size(), 4u);
  const survey::SurveyInput input = make_input(lab, session);
  // The pauses seen by two or more cameras are found.
  int wand = 0;
  for (const auto& in : input.instants)
    if (in.id >= 30 && in.views.size() >= 2) ++wand;
  EXPECT_GE(wand, 30);  // of 48 pauses (2 loops x 12 x 2 markers), some in one camera's view only
  const survey::SurveyResult r = survey::run_survey(input);
  ASSERT_EQ(r.cameras.size(), 4u);
  for (std::size_t c = 0; c < 4; ++c) {
    const sim::SceneCamera& truth = lab.scene.cameras[c];
    const double dp = (r.cameras[c].centre - truth.position).norm();
    const double da = Eigen::AngleAxisd(r.cameras[c].R_wc.transpose() * truth.R_wc).angle() * 180 / M_PI;
    std::printf("[ survey   ] %s: position error %.2f mm, orientation %.4f deg, rms %.3f px, sigma %.2f mm\n",
                truth.name.c_str(), dp * 1e3, da, r.cameras[c].rms_px, r.cameras[c].sigma.norm() * 1e3);
    // Cameras a, b see references; c and d are placed through the wand only, d at the end
    // of the chain (its error is the largest, ~3-4 mm here).
    EXPECT_LT(dp, 0.006) << truth.name;
    EXPECT_LT(da, 0.1) << truth.name;
    EXPECT_LT(r.cameras[c].rms_px, 0.3) << truth.name;
    // The covariance's 1-sigma is the right size: the true error is within 5 sigma, and
    // sigma is not absurdly large.
    ASSERT_TRUE(r.cameras[c].covariance_ok) << truth.name;
    EXPECT_LT(dp, 3 * r.cameras[c].sigma.norm() + 5e-4) << truth.name;
    EXPECT_LT(r.cameras[c].sigma.norm(), 0.01) << truth.name;
  }
  ASSERT_EQ(r.references.size(), 3u);
  for (const auto& ref : r.references) {
    ASSERT_FALSE(ref.left_out.empty()) << ref.id;
    for (const auto& [name, e] : ref.left_out) {
      std::printf("[ survey   ] reference %d in %s: fit %.2f mm, left out %.2f mm\n", ref.id, name.c_str(),
                  ref.residual.at(name).norm() * 1e3, e.norm() * 1e3);
      EXPECT_LT(e.norm(), 0.005) << ref.id << " " << name;
    }
  }
  EXPECT_EQ(r.cameras[3].references_seen, 0) << "camera d must see no reference (the lab's point)";
  EXPECT_GT(r.cameras[0].references_seen, 0);
  fs::remove_all(lab.dir);
}

TEST(SurveySolve, BadInputIsNamed) {
  const Lab lab = make_session("bad", 23.0, 15.0, 0.15, {20, 21, 22});
  const survey::Session session = survey::load_session(lab.dir / "session");
  survey::SurveyInput input = make_input(lab, session);
  try {
    survey::run_survey(input);
    FAIL() << "no reference seen, yet the survey ran";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("references: 0 of the listed markers"), std::string::npos) << e.what();
  }
  // Camera d cut off: only instants before the wand reaches the c/d overlap.
  input = make_input(lab, session);
  for (auto& in : input.instants)
    for (auto it = in.views.begin(); it != in.views.end();)
      it = (it->camera == 3 || it->camera == 2) && in.id >= 30 ? in.views.erase(it) : it + 1;
  input.references = {
      {20, {1.6, 0.8, 0}, std::nullopt}, {21, {3.4, 1.4, 0}, std::nullopt}, {22, {2.0, 3.3, 0}, std::nullopt}};
  try {
    survey::run_survey(input);
    FAIL() << "cameras c and d are connected to nothing, yet the survey ran";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'c'"), std::string::npos) << e.what();
  }
  fs::remove_all(lab.dir);
}

TEST(SurveySolve, SessionFileErrorsNameFileAndLine) {
  const fs::path dir = fs::temp_directory_path() / ("ips_survey_files_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "session.txt") << "ips-record 1\nconfig x.yaml\nfingerprint 0123\ncamera a a.det\n";
  std::ofstream(dir / "a.det") << "# t_ns id corners\n100 3 1 2 3 4 5 6 7 8\n200 3 1 2 3 x 5 6 7 8\n";
  try {
    survey::load_session(dir);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("a.det:3"), std::string::npos) << e.what();
  }
  std::ofstream(dir / "refs.yaml") << "references:\n  - {id: 1, x: 0, y: 0}\n  - {id: 2, x: 1, y: 0, w: 3}\n";
  try {
    survey::load_references(dir / "refs.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("refs.yaml:3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'w'"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

// The still-period finder against hand-made tracks: a marker still for 1 s, moving, still
// again; a second camera with a 20 ms phase sees the same pauses: two instants, two views each.
TEST(SurveySolve, StillPeriodsOverlapAcrossPhases) {
  survey::Session s;
  for (int c = 0; c < 2; ++c) {
    survey::SessionCamera cam{c ? "b" : "a", "", {}};
    for (int k = 0; k < 90; ++k) {
      const double t = k / 30.0 + 0.02 * c;
      const double x = t < 1.0 ? 100.0 : (t < 2.0 ? 100.0 + 50 * (t - 1.0) : 150.0);
      survey::Detection d;
      d.t_ns = std::llround(t * 1e9);
      d.id = 5;
      d.corners = {Point2{x, 10 + 0.1 * (k % 2)}, Point2{x + 20, 10}, Point2{x + 20, 30}, Point2{x, 30}};
      cam.detections.push_back(d);
    }
    s.cameras.push_back(cam);
  }
  const auto periods = survey::find_still_periods(s, {});
  ASSERT_EQ(periods.size(), 4u);
  const auto instants = survey::group_instants(periods, 0.1);
  ASSERT_EQ(instants.size(), 2u);
  for (const auto& in : instants) EXPECT_EQ(in.views.size(), 2u);
  EXPECT_NEAR(instants[0].views[0].corners[0].x, 100.0, 1e-9);
  EXPECT_NEAR(instants[1].views[0].corners[0].x, 150.0, 1e-9);
}

}  // namespace
}  // namespace ips

namespace ips {
namespace {

// `ips survey` as a program on the projected session: the config the session names gives
// the same cameras (written model loads as `plane`); a config whose camera d has another
// lens is refused (exit 2, the fingerprint named, nothing written).
TEST(SurveySolve, CommandWritesPlaneModelAndRefusesAnotherConfig) {
  const Lab lab = make_session("cli", 61.0, 15.0, 0.15);
  const fs::path dir = lab.dir;
  auto config = [&](const std::string& scene) {
    std::string c = "cameras:\n";
    for (const auto& cam : test::lab_cameras())
      c += std::string("  - {name: ") + cam.name + ", source: synthetic, scene: " + scene + "}\n";
    return c + "markers: {edge_length: 0.20}\nmodel_file: model.json\n";
  };
  std::ofstream(dir / "ipsd.yaml") << config("lab.yaml");
  std::string other = test::lab_scene(IPS_TEST_DATA_DIR, 1.0, 1.0);
  other.replace(other.rfind("intrinsics_red.yaml"), 19, "intrinsics_white.yaml");  // camera d's lens
  std::ofstream(dir / "other.yaml") << other;
  std::ofstream(dir / "other_ipsd.yaml") << config("other.yaml");
  std::string refs = "references:\n";
  for (const auto& r : test::lab_references())
    refs += "  - {id: " + std::to_string(r.id) + ", x: " + std::to_string(r.x) + ", y: " + std::to_string(r.y) + "}\n";
  std::ofstream(dir / "refs.yaml") << refs;
  const fs::path log = dir / "log.txt";
  const auto limit = std::chrono::seconds(static_cast<long>(60 * test::kTimeScale));
  EXPECT_EQ(test::run({test::bin("ips"), "survey", "--session", (dir / "session").string(), "--references",
                       (dir / "refs.yaml").string(), "--config", (dir / "other_ipsd.yaml").string(), "--out",
                       (dir / "bad.json").string()},
                      log, limit),
            2);
  EXPECT_NE(test::read_file(log).find("recorded with other cameras or intrinsics"), std::string::npos)
      << test::read_file(log);
  EXPECT_FALSE(fs::exists(dir / "bad.json"));
  ASSERT_EQ(test::run({test::bin("ips"), "survey", "--session", (dir / "session").string(), "--references",
                       (dir / "refs.yaml").string(), "--config", (dir / "ipsd.yaml").string(), "--out",
                       (dir / "model.json").string()},
                      log, limit),
            0)
      << test::read_file(log);
  // `ips record` refuses to overwrite a session and a bad --seconds, before opening a camera.
  EXPECT_EQ(test::run({test::bin("ips"), "record", "--config", (dir / "ipsd.yaml").string(), "--seconds", "5", "--out",
                       (dir / "session").string()},
                      log, limit),
            2);
  EXPECT_NE(test::read_file(log).find("already holds a session"), std::string::npos) << test::read_file(log);
  EXPECT_EQ(test::run({test::bin("ips"), "record", "--config", (dir / "ipsd.yaml").string(), "--seconds", "0", "--out",
                       (dir / "new").string()},
                      log, limit),
            2);
  EXPECT_FALSE(fs::exists(dir / "new"));
  const ModelSet models = load_model_file(dir / "model.json");
  for (const auto& cam : lab.scene.cameras) {
    const Mapper* m = models.find(cam.name);
    ASSERT_NE(m, nullptr) << cam.name;
    // A floor point below the camera's true view, through the surveyed plane model.
    const Eigen::Vector3d world(cam.position.x() + 0.3, cam.position.y() - 0.2, 0.1);
    const Eigen::Vector3d p = m->predict(cam.world_to_camera(world), world.z());
    EXPECT_LT((p - world).head<2>().norm(), 0.003) << cam.name;
  }
  fs::remove_all(dir);
}

// The scene's waypoint pause: the marker stands at each waypoint for `pause` seconds, then
// moves at `speed` (what the survey tests' wand relies on).
TEST(SurveySolve, SceneWaypointPauseHoldsTheMarkerStill) {
  const fs::path dir = fs::temp_directory_path() / ("ips_survey_pause_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "s.yaml") << test::lab_scene(IPS_TEST_DATA_DIR, 1.0, 0.5);
  const sim::Scene s = sim::Scene::load(dir / "s.yaml");
  const auto pts = test::lab_wand_points();
  const sim::MarkerPose a = s.marker_pose(30, 0.0), b = s.marker_pose(30, 0.99);
  EXPECT_NEAR(a.x, pts[0].first, 1e-9);
  EXPECT_NEAR(a.y, pts[0].second, 1e-9);
  EXPECT_NEAR(b.x, a.x, 1e-12);
  EXPECT_NEAR(b.yaw, a.yaw, 1e-12);
  const double leg = std::hypot(pts[1].first - pts[0].first, pts[1].second - pts[0].second);
  const sim::MarkerPose c = s.marker_pose(30, 1.5);  // 0.5 s after leaving: 0.25 m along
  EXPECT_NEAR(std::hypot(c.x - a.x, c.y - a.y), 0.25, 1e-9);
  const sim::MarkerPose d = s.marker_pose(30, 1.0 + leg / 0.5 + 0.5);  // pausing at point 1
  EXPECT_NEAR(d.x, pts[1].first, 1e-9);
  EXPECT_NEAR(d.y, pts[1].second, 1e-9);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ips
