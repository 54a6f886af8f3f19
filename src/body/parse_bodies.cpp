// bodies: rigid bodies of markers (ips/body/body.h). The body reader is shared with the simulator's
// scenes; here its errors get the config's "file:line:column: key: what" form, and the ids are
// checked against the dictionary and the markers section.
#include <sstream>

#include <opencv2/aruco.hpp>

#include "body/parse_bodies.h"
#include "core/map_reader.h"
#include "ips/body/body.h"
#include "ips/detect/detector.h"

namespace ips::config_detail {

std::vector<BodyDef> parse_bodies(const YAML::Node& n, const MarkerConfig& markers, const std::string& file) {
  const BodyFail fail = [&](const YAML::Node& at, const std::string& key, const std::string& what) {
    std::ostringstream s;
    s << file;
    const YAML::Mark mark = at.Mark();
    if (mark.line >= 0) s << ':' << mark.line + 1 << ':' << mark.column + 1;
    s << ": " << key << ": " << what;
    throw InputError(s.str());
  };
  if (!n.IsSequence() || n.size() == 0) fail(n, "bodies", "expected a non-empty list of bodies");
  const int dictionary_size = cv::aruco::getPredefinedDictionary(dictionary_id(markers.dictionary))->bytesList.rows;
  std::vector<BodyDef> bodies;
  std::vector<YAML::Node> nodes;
  for (std::size_t i = 0; i < n.size(); ++i) {
    const std::string key = "bodies[" + std::to_string(i) + "]";
    bodies.push_back(parse_body(n[i], key, {}, fail));
    nodes.push_back(n[i]);
    for (const BodyMarker& m : bodies.back().markers) {
      if (m.id >= dictionary_size)
        fail(n[i], key, "marker id " + std::to_string(m.id) + " is not in " + markers.dictionary);
      const auto it = markers.ids.find(m.id);
      if (it != markers.ids.end() && it->second.fixed)
        fail(n[i], key,
             "marker id " + std::to_string(m.id) + " is a fixed marker (markers.ids." + std::to_string(m.id) +
                 ".fixed)");
    }
  }
  check_bodies(bodies, nodes, "bodies", fail);
  return bodies;
}

}  // namespace ips::config_detail
