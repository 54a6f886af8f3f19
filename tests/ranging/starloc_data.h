// The STAR-loc dataset's sequence loop-2d-fast_s2 (Dümbgen et al., arXiv:2309.05518,
// utiasASRL/starloc) as the ranging tests read it: from the shared data folder beside the
// repository (never copied into it; IPS_STARLOC_DIR moves it). Test input only.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace ips {

inline std::filesystem::path starloc_dir() {
  if (const char* env = std::getenv("IPS_STARLOC_DIR")) return env;
  return std::filesystem::path(IPS_CONFIG_DIR) / ".." / ".." / "shared" / "data" / "starloc";
}

inline std::vector<std::string> split_starloc_csv(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) out.push_back(cell);
  return out;
}

struct StarLocRow {
  double t = 0, range = 0, range_calib = 0, std_m = 0, gt_range = 0;
  int tag = 0, anchor = 0;
  Eigen::Vector3d truth;
};

struct StarLocSequence {
  std::vector<StarLocRow> rows;              // time order
  std::map<int, Eigen::Vector3d> anchor_of;  // UWB module id -> position (Vicon frame)
};

// Loads loop-2d-fast_s2 (present = false where the data is absent).
inline void load_starloc(StarLocSequence& seq, bool& present) {
  auto& rows = seq.rows;
  auto& anchor_of = seq.anchor_of;
  present = false;
  const auto dir = starloc_dir();
  const auto csv = dir / "data" / "loop-2d-fast_s2" / "uwb.csv";
  if (!std::filesystem::exists(csv)) return;
  present = true;
  // Anchor positions (Vicon frame) by marker id.
  std::map<int, Eigen::Vector3d> markers;
  {
    std::ifstream in(dir / "mocap" / "uwb_markers_v1.csv");
    std::string line;
    std::getline(in, line);
    while (std::getline(in, line)) {
      const auto c = split_starloc_csv(line);
      ASSERT_EQ(c.size(), 4u) << line;
      markers[std::stoi(c[0])] = {std::stod(c[1]), std::stod(c[2]), std::stod(c[3])};
    }
  }
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  const auto header = split_starloc_csv(line);
  std::map<std::string, std::size_t> col;
  for (std::size_t i = 0; i < header.size(); ++i) col[header[i]] = i;
  for (const char* name : {"time_s", "range", "from_id", "to_id", "tag_pos_x", "gt_range", "range_calib", "std"})
    ASSERT_TRUE(col.count(name)) << "uwb.csv has no column " << name;
  while (std::getline(in, line)) {
    const auto c = split_starloc_csv(line);
    if (c.size() < header.size() || c[col["tag_pos_x"]].empty() || c[col["range_calib"]].empty()) continue;
    StarLocRow r;
    r.t = std::stod(c[col["time_s"]]);
    r.range = std::stod(c[col["range"]]);
    r.range_calib = std::stod(c[col["range_calib"]]);
    r.std_m = std::stod(c[col["std"]]);
    r.gt_range = std::stod(c[col["gt_range"]]);
    r.tag = std::stoi(c[col["from_id"]]);
    r.anchor = std::stoi(c[col["to_id"]]);
    r.truth = {std::stod(c[col["tag_pos_x"]]), std::stod(c[col["tag_pos_y"]]), std::stod(c[col["tag_pos_z"]])};
    rows.push_back(r);
  }
  ASSERT_GT(rows.size(), 7000u);
  // The ranges' anchor ids are the UWB modules', not the marker file's: each module is the one
  // marker whose distance to the true tag position is the dataset's gt_range (to 1e-9 m).
  for (const StarLocRow& r : rows) {
    if (anchor_of.count(r.anchor)) continue;
    for (const auto& [id, pos] : markers)
      if (std::abs((pos - r.truth).norm() - r.gt_range) < 1e-9) anchor_of[r.anchor] = pos;
    ASSERT_TRUE(anchor_of.count(r.anchor)) << "no marker at gt_range of UWB anchor " << r.anchor;
  }
  ASSERT_EQ(anchor_of.size(), 8u);
}

/// Every 100 ms of [from, to) and for each of the two tags: its latest range to each anchor
/// within the last 70 ms (one round of the 8 anchors), if there are >= 6, with the newest of them
/// (whose truth is the tag's position then): `round(latest by anchor id, newest)`.
template <typename Round>
void for_each_round(const StarLocSequence& seq, double from, double to, Round round) {
  const auto& rows = seq.rows;
  std::size_t end = 0;
  for (double t = from + 0.1; t < to; t += 0.1) {
    while (end < rows.size() && rows[end].t <= t) ++end;
    for (int tag : {1, 2}) {
      std::map<int, const StarLocRow*> latest;
      for (std::size_t i = end; i-- > 0 && rows[i].t > t - 0.07;)
        if (rows[i].tag == tag && !latest.count(rows[i].anchor)) latest[rows[i].anchor] = &rows[i];
      if (latest.size() < 6) continue;
      const StarLocRow* newest = nullptr;
      for (const auto& [anchor, r] : latest)
        if (!newest || r->t > newest->t) newest = r;
      round(latest, *newest);
    }
  }
}

}  // namespace ips
