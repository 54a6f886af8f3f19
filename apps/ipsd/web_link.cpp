#include "web_link.h"

#include <cmath>

#include "ips/mapping/mapper.h"

namespace ipsd {

std::string web_layout(const Runtime& rt) {
  const ips::DaemonConfig& config = rt.config;
  nlohmann::json j;
  j["floor"] = config.web.floor.size() == 4 ? nlohmann::json(config.web.floor) : nlohmann::json(nullptr);
  j["update_rate"] = config.web.update_rate_hz;
  j["camera_fps"] = config.web.camera_fps;
  j["cameras"] = nlohmann::json::array();
  for (const auto& cam : config.cameras) {
    const auto i = static_cast<std::size_t>(cam.index);
    nlohmann::json c{{"name", cam.name}, {"index", cam.index}, {"fps", cam.fps}};
    if (const ips::Mapper* mapper = rt.mappers[i]) {
      c["mapper"] = mapper->method();
      // The floor the markers lie on: the markers' default height (0 if unknown).
      const double z = std::isnan(config.markers.height) ? 0.0 : config.markers.height;
      nlohmann::json footprint = nlohmann::json::array();
      for (const auto& p : ips::camera_footprint(rt.intrinsics[i], *mapper, z)) footprint.push_back({p.x(), p.y()});
      c["footprint"] = footprint;
      Eigen::Vector3d origin, dir;
      c["position"] = mapper->world_ray(Eigen::Vector3d(0, 0, 1), origin, dir)
                          ? nlohmann::json({origin.x(), origin.y(), origin.z()})
                          : nlohmann::json(nullptr);
    } else {  // rides on a robot (cameras[].on_robot): it moves with the robot's marker
      c["mapper"] = "inside-out";
      c["footprint"] = nlohmann::json::array();
      c["position"] = nullptr;
      c["on_robot"] = config.on_robot.at(cam.index).marker;
    }
    nlohmann::json controls = nlohmann::json::object();
    if (cam.v4l2.controls.auto_exposure) controls["auto_exposure"] = *cam.v4l2.controls.auto_exposure;
    if (cam.v4l2.controls.exposure_s) controls["exposure_s"] = *cam.v4l2.controls.exposure_s;
    if (cam.v4l2.controls.gain) controls["gain"] = *cam.v4l2.controls.gain;
    if (cam.v4l2.controls.autofocus) controls["autofocus"] = *cam.v4l2.controls.autofocus;
    if (cam.v4l2.controls.power_line_hz) controls["power_line_hz"] = *cam.v4l2.controls.power_line_hz;
    c["controls"] = controls;
    c["size"] = {rt.intrinsics[i].size().width, rt.intrinsics[i].size().height};
    j["cameras"].push_back(c);
  }
  j["markers"] = nlohmann::json::object();
  for (const auto& [id, info] : config.markers.ids)
    if (!info.name.empty() && info.publish) j["markers"][std::to_string(id)] = info.name;  // unpublished: never shown
  j["bodies"] = body_layout(config.bodies);
  return j.dump();
}

nlohmann::json body_layout(const std::vector<ips::BodyDef>& bodies) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& body : bodies) {
    nlohmann::json faces = nlohmann::json::array();
    for (const auto& m : body.markers) {
      // The plate's corners seen from above (body x, y): a square for a face-up marker, a
      // line for a side face. The page turns them by the body's yaw.
      const Eigen::Vector3d half_x = 0.5 * m.plate * m.axes.col(0), half_y = 0.5 * m.plate * m.axes.col(1);
      nlohmann::json outline = nlohmann::json::array();
      const Eigen::Vector3d corners[] = {m.position - half_x - half_y, m.position + half_x - half_y,
                                         m.position + half_x + half_y, m.position - half_x + half_y};
      for (const Eigen::Vector3d& c : corners) outline.push_back({c.x(), c.y()});
      faces.push_back({{"id", m.id}, {"edge", m.edge}, {"plate", m.plate}, {"outline", outline}});
    }
    out.push_back({{"name", body.name}, {"ground", body.ground}, {"markers", faces}});
  }
  return out;
}

nlohmann::json web_counters_json(const ips::WebCounters& c) {
  return {{"clients", c.clients}, {"clients_total", c.clients_total},
          {"refused", c.refused}, {"messages", c.messages},
          {"dropped", c.dropped}, {"inbox_dropped", c.inbox_dropped},
          {"frames", c.frames},   {"bad_requests", c.bad_requests},
          {"limited", c.limited}};
}

}  // namespace ipsd
