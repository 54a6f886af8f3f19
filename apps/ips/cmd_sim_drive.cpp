// `ips sim drive`: what a camera riding on a robot sees of the ceiling's markers while the robot
// drives (inside-out, docs/inside-out.md): the frames, times.csv (`ips localise --images`),
// the robot's exact pose per frame (truth.csv) and the exact map of the ceiling (map.json).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "command.h"
#include "image_io.h"
#include "ips/core/error.h"
#include "ips/sim/ceiling.h"
#include "ips/sim/renderer.h"
#include "ips/sim/scene.h"

namespace fs = std::filesystem;

namespace cmd_sim_drive {  // named, not anonymous: unique in a unity build

struct Args {
  std::string scene, out, camera;
  double seconds = 10.0, fps = 10.0, start = 0.0;
};

int run(const Args& a) {
  if (!(a.fps > 0 && a.fps <= 1000)) throw ips::InputError("--fps must be in (0, 1000]");
  if (!(a.seconds > 0)) throw ips::InputError("--seconds must be > 0");
  const ips::sim::Scene scene = ips::sim::Scene::load(a.scene);
  const std::size_t index = scene.camera_index(a.camera);
  const ips::sim::SceneCamera& cam = scene.cameras[index];
  if (!cam.looks_up) throw ips::InputError(a.scene + ": camera '" + a.camera + "' does not look up (looking: up)");
  const ips::CeilingMap map = ips::sim::ceiling_map(scene);
  if (map.markers.empty()) {
    throw ips::InputError(a.scene + ": no marker on the ceiling (markers[].facing: down, height: the ceiling's)");
  }
  const fs::path out(a.out);
  fs::create_directories(out / "frames");
  ips::cli::write_file_atomically(out / "map.json", map.to_json());
  std::ofstream times(out / "times.csv"), truth(out / "truth.csv");
  times << "file,t_ns\n";
  truth << "t_ns,x,y,z,yaw\n";
  const ips::sim::CameraRenderer renderer(scene, index);
  const int frames = static_cast<int>(std::floor(a.seconds * a.fps + 1e-9));
  cv::Mat gray;
  for (int k = 0; k < frames; ++k) {
    const double t = a.start + k / a.fps;
    const auto t_ns = static_cast<long long>(std::llround(t * 1e9));
    renderer.render(t, gray, static_cast<std::uint64_t>(k));
    const int quality = scene.render.jpeg_quality > 0 ? scene.render.jpeg_quality : 95;
    const auto bytes = ips::sim::encode_jpeg(gray, quality, true, scene.render.jpeg_restart_rows);
    char name[32];
    std::snprintf(name, sizeof name, "frames/%06d.jpg", k);
    ips::cli::write_file_atomically(out / name, std::string(bytes.begin(), bytes.end()));
    const ips::sim::MarkerPose p = scene.carrier_pose_at(index, t);
    times << name << ',' << t_ns << '\n';
    char row[160];
    std::snprintf(row, sizeof row, "%lld,%.6f,%.6f,%.6f,%.6f\n", t_ns, p.x, p.y, p.z, p.yaw);
    truth << row;
    if ((k + 1) % 50 == 0 || k + 1 == frames) std::fprintf(stderr, "\rframe %d/%d", k + 1, frames);
  }
  std::fprintf(stderr, "\n");
  times.flush();
  truth.flush();
  if (!times || !truth) throw std::runtime_error("cannot write " + out.string() + "/times.csv or truth.csv");
  std::printf("wrote %d frames of camera %s, times.csv, truth.csv and map.json (%zu ceiling markers) to %s\n", frames,
              a.camera.c_str(), map.markers.size(), a.out.c_str());
  return 0;
}

IPS_REGISTER_SIM_COMMAND(
    "drive", "Frames of a camera that rides on a robot and looks up at the ceiling's markers, with the exact truth",
    [](CLI::App& sub) -> std::function<int()> {
      auto a = std::make_shared<Args>();
      sub.add_option("--scene", a->scene, "Scene YAML file")->required();
      sub.add_option("--camera", a->camera, "The riding camera (cameras[].looking: up, with a trajectory)")->required();
      sub.add_option("--out", a->out, "Output directory (created): frames/, times.csv, truth.csv, map.json")
          ->required();
      sub.add_option("--seconds", a->seconds, "Scene time to drive")->capture_default_str();
      sub.add_option("--fps", a->fps, "Frames per second of scene time")->capture_default_str();
      sub.add_option("--start", a->start, "Scene time of the first frame, s")->capture_default_str();
      return [a] { return run(*a); };
    });

}  // namespace cmd_sim_drive
