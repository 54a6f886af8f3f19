// The `ips record` session files (format: include/ips/survey/survey.h) and refs.yaml.
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "ips/core/error.h"
#include "ips/survey/survey.h"

namespace ips::survey {
namespace {

void fnv(std::uint64_t& h, const void* data, std::size_t n) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < n; ++i) {
    h ^= p[i];
    h *= 1099511628211ULL;
  }
}

// Numbers are hashed as printed with 9 significant digits, so a re-saved intrinsics file
// (the same values up to the last bits) keeps its fingerprint.
void fnv_number(std::uint64_t& h, double v) {
  char buf[40];
  const int n = std::snprintf(buf, sizeof buf, "%.9g;", v);
  fnv(h, buf, static_cast<std::size_t>(n));
}

std::string where(const std::filesystem::path& file, int line) { return file.string() + ":" + std::to_string(line); }

}  // namespace

std::string camera_fingerprint(const std::vector<std::pair<std::string, CameraModel>>& cameras) {
  std::uint64_t h = 14695981039346656037ULL;
  for (const auto& [name, m] : cameras) {
    fnv(h, name.data(), name.size());
    fnv(h, ";", 1);
    fnv_number(h, m.size().width);
    fnv_number(h, m.size().height);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) fnv_number(h, m.K()(r, c));
    for (double d : m.D()) fnv_number(h, d);
    fnv(h, "|", 1);
  }
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016" PRIx64, h);
  return buf;
}

std::string session_header(const Session& s) {
  std::ostringstream o;
  o << "# ips record session: the detections of every camera, one file per camera\n"
    << "# (lines: t_ns id x0 y0 x1 y1 x2 y2 x3 y3; docs/survey.md).\n"
    << kSessionFormat << " " << kSessionVersion << "\n"
    << "config " << s.config << "\n"
    << "fingerprint " << s.fingerprint << "\n"
    << "dictionary " << s.dictionary << "\n";
  char buf[64];
  std::snprintf(buf, sizeof buf, "seconds %.3f\n", s.seconds);
  o << buf;
  for (const auto& c : s.cameras) o << "camera " << c.name << " " << c.file << "\n";
  return o.str();
}

std::string detection_line(const Detection& d) {
  char buf[200];
  std::snprintf(buf, sizeof buf, "%" PRId64 " %d %.3f %.3f %.3f %.3f %.3f %.3f %.3f %.3f", d.t_ns, d.id, d.corners[0].x,
                d.corners[0].y, d.corners[1].x, d.corners[1].y, d.corners[2].x, d.corners[2].y, d.corners[3].x,
                d.corners[3].y);
  return buf;
}

Session load_session(const std::filesystem::path& dir) {
  Session s;
  s.dir = dir;
  const auto header = dir / "session.txt";
  std::ifstream in(header);
  if (!in) throw InputError(header.string() + ": cannot open (not an `ips record` session directory)");
  std::string line;
  int n = 0;
  bool format_seen = false;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::string key;
    ls >> key;
    std::string rest;
    std::getline(ls >> std::ws, rest);
    if (key == kSessionFormat) {
      if (rest != std::to_string(kSessionVersion))
        throw InputError(where(header, n) + ": session version " + rest + " is not supported (this build reads " +
                         std::to_string(kSessionVersion) + ")");
      format_seen = true;
    } else if (!format_seen) {
      throw InputError(where(header, n) + ": expected \"" + kSessionFormat + " " + std::to_string(kSessionVersion) +
                       "\" first");
    } else if (key == "config") {
      s.config = rest;
    } else if (key == "fingerprint") {
      s.fingerprint = rest;
    } else if (key == "dictionary") {
      s.dictionary = rest;
    } else if (key == "seconds") {
      try {
        s.seconds = std::stod(rest);
      } catch (const std::exception&) {
        throw InputError(where(header, n) + ": seconds: not a number '" + rest + "'");
      }
    } else if (key == "camera") {
      SessionCamera c;
      std::istringstream cs(rest);
      if (!(cs >> c.name >> c.file) || c.file.find('/') != std::string::npos)
        throw InputError(where(header, n) + ": expected \"camera NAME FILE\" (FILE in the session directory)");
      s.cameras.push_back(c);
    } else {
      throw InputError(where(header, n) + ": unknown key '" + key + "'");
    }
  }
  if (!format_seen) throw InputError(header.string() + ": not an `ips record` session (no format line)");
  if (s.cameras.empty()) throw InputError(header.string() + ": names no camera");
  if (s.fingerprint.empty()) throw InputError(header.string() + ": no fingerprint line");
  for (auto& c : s.cameras) {
    const auto path = dir / c.file;
    std::ifstream f(path);
    if (!f) throw InputError(path.string() + ": cannot open (camera " + c.name + " of " + header.string() + ")");
    int k = 0;
    while (std::getline(f, line)) {
      ++k;
      if (line.empty() || line[0] == '#') continue;
      Detection d;
      std::istringstream ls(line);
      ls >> d.t_ns >> d.id;
      for (auto& p : d.corners) ls >> p.x >> p.y;
      std::string extra;
      bool finite = true;
      for (const auto& p : d.corners) finite = finite && std::isfinite(p.x) && std::isfinite(p.y);
      if (ls.fail() || (ls >> extra) || d.id < 0 || !finite) {
        // The last line of a recording cut short (the program killed) may be partial.
        if (f.eof()) break;  // getline met the end without a newline
        throw InputError(where(path, k) + ": expected \"t_ns id x0 y0 x1 y1 x2 y2 x3 y3\", got '" + line + "'");
      }
      c.detections.push_back(d);
    }
  }
  return s;
}

std::vector<Reference> load_references(const std::filesystem::path& path, std::size_t min_references) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path.string());
  } catch (const YAML::BadFile&) {
    throw InputError(path.string() + ": cannot open the references file");
  } catch (const YAML::Exception& e) {
    throw InputError(path.string() + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  const YAML::Node list = root["references"];
  if (!list || !list.IsSequence())
    throw InputError(path.string() + ": expected `references: [{id: N, x: X, y: Y, z: Z}, ...]`");
  std::vector<Reference> refs;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YAML::Node n = list[i];
    const std::string at =
        path.string() + ":" + std::to_string(n.Mark().line + 1) + ": references[" + std::to_string(i) + "]";
    if (!n.IsMap()) throw InputError(at + ": expected {id: N, x: X, y: Y, z: Z}");
    for (const auto& kv : n) {
      if (!kv.first.IsScalar()) throw InputError(at + ": a key must be a plain word (id, x, y, z, yaw_deg)");
      const auto key = kv.first.as<std::string>();
      if (key != "id" && key != "x" && key != "y" && key != "z" && key != "yaw_deg")
        throw InputError(at + ": unknown key '" + key + "' (id, x, y, z, yaw_deg)");
    }
    Reference r;
    try {
      if (!n["id"] || !n["x"] || !n["y"]) throw InputError(at + ": id, x and y are required");
      r.id = n["id"].as<int>();
      r.position = {n["x"].as<double>(), n["y"].as<double>(), n["z"] ? n["z"].as<double>() : 0.0};
      if (n["yaw_deg"]) r.yaw = n["yaw_deg"].as<double>() * M_PI / 180.0;
    } catch (const YAML::Exception&) {
      throw InputError(at + ": id must be an integer and x, y, z, yaw_deg numbers");
    }
    if (r.id < 0 || !r.position.allFinite() || (r.yaw && !std::isfinite(*r.yaw)))
      throw InputError(at + ": id must be >= 0 and x, y, z, yaw_deg finite");
    for (const auto& o : refs)
      if (o.id == r.id) throw InputError(at + ": marker " + std::to_string(r.id) + " is listed twice");
    refs.push_back(r);
  }
  if (refs.size() < min_references)
    throw InputError(path.string() + ": " + std::to_string(refs.size()) + " reference(s); at least " +
                     std::to_string(min_references) + " markers at known positions are needed");
  return refs;
}

}  // namespace ips::survey
