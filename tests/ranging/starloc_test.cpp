// The range solvers on real UWB ranges with motion-capture truth: the STAR-loc dataset
// (Dümbgen et al., arXiv:2309.05518, utiasASRL/starloc), sequence loop-2d-fast_s2, read from
// the shared data folder beside the repository (never copied into it; IPS_STARLOC_DIR moves it).
// Skipped, saying so, where that folder is absent.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "ips/input/range_admission.h"
#include "ips/input/range_datagram.h"
#include "ips/input/range_fixer.h"
#include "ips/ranging/multilateration.h"
#include "ips/ranging/range_tracker.h"
#include "starloc_data.h"

namespace ips {
namespace {

double pct(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(p * double(v.size() - 1))];
}

TEST(StarLoc, LeastSquaresOnRealUwbRangesAgainstMotionCapture) {
  StarLocSequence seq;
  bool present = false;
  load_starloc(seq, present);
  if (HasFatalFailure()) return;
  if (!present) GTEST_SKIP() << "no STAR-loc data at " << starloc_dir() << " (IPS_STARLOC_DIR)";
  const auto& rows = seq.rows;
  auto& anchor_of = seq.anchor_of;
  // Every 100 ms and for each tag: the latest range to each anchor within the last 70 ms (one
  // round of the 8 anchors); the truth is the tag's position at the last of them.
  const auto solve_all = [&](bool calibrated, bool height_known, std::vector<double>& horizontal,
                             std::vector<double>& vertical) {
    for_each_round(seq, 0.0, rows.back().t,
                   [&](const std::map<int, const StarLocRow*>& latest, const StarLocRow& last) {
                     std::vector<RangeToAnchor> ranges;
                     for (const auto& [anchor, r] : latest)
                       ranges.push_back(
                           {anchor_of[anchor], calibrated ? r->range_calib : r->range, r->std_m > 0 ? r->std_m : 0.1});
                     RangeSolveOptions options;
                     if (height_known) options.known_height = last.truth.z();
                     const RangeFix fix = fix_least_squares(ranges, options);
                     ASSERT_TRUE(fix.ok) << fix.why;
                     horizontal.push_back((fix.position - last.truth).head<2>().norm());
                     vertical.push_back(std::abs(fix.position.z() - last.truth.z()));
                   });
  };
  std::vector<double> h_cal, v_cal, h_raw, v_raw, h_known, v_known;
  solve_all(true, false, h_cal, v_cal);
  solve_all(false, false, h_raw, v_raw);
  solve_all(true, true, h_known, v_known);
  std::printf("known height: horizontal p50 %.1f p95 %.1f cm\n", 100 * pct(h_known, 0.5), 100 * pct(h_known, 0.95));
  ASSERT_GT(h_cal.size(), 500u);
  std::printf(
      "STAR-loc loop-2d-fast_s2, %zu fixes: calibrated ranges horizontal p50 %.1f p95 %.1f cm, vertical p50 "
      "%.1f p95 %.1f cm; raw ranges horizontal p50 %.1f p95 %.1f cm, vertical p50 %.1f p95 %.1f cm\n",
      h_cal.size(), 100 * pct(h_cal, 0.5), 100 * pct(h_cal, 0.95), 100 * pct(v_cal, 0.5), 100 * pct(v_cal, 0.95),
      100 * pct(h_raw, 0.5), 100 * pct(h_raw, 0.95), 100 * pct(v_raw, 0.5), 100 * pct(v_raw, 0.95));
  // Measured 2026-11-26 (docs/ranging.md): 14.6 / 48.6 cm horizontal, 37.8 cm vertical p50;
  // 10.1 / 30.1 cm at a known height; raw ranges 18.2 / 51.5 cm. The bounds leave ~30 %.
  EXPECT_LT(pct(h_cal, 0.5), 0.19);
  EXPECT_LT(pct(h_cal, 0.95), 0.63);
  EXPECT_LT(pct(v_cal, 0.5), 0.50);
  EXPECT_LT(pct(h_known, 0.5), 0.13);
  EXPECT_LT(pct(h_known, 0.95), 0.40);
  // The dataset's bias calibration helps, most of all in height.
  EXPECT_LT(pct(h_cal, 0.5), pct(h_raw, 0.5));
  EXPECT_LT(pct(v_cal, 0.5), pct(v_raw, 0.5));
}

// The comparison: the ranges replayed in time order through the range input as ipsd
// takes them (each range one datagram, one firing: encoded, admitted, handed to the fixer with
// its default ranging.track), as a UWB module sends them. The baseline: every 100 ms, each
// tag's latest range to each anchor within the last 70 ms (>= 4 anchors), unweighted least
// squares. Both against the tag's motion-capture position at its latest range; raw ranges (the
// dataset's bias calibration is not used: biases are the tracker's job).
TEST(StarLoc, ReplayedThroughTheRangeInputTheTrackerBeatsTheSlidingWindowBaseline) {
  StarLocSequence seq;
  bool present = false;
  load_starloc(seq, present);
  if (HasFatalFailure()) return;
  if (!present) GTEST_SKIP() << "no STAR-loc data at " << starloc_dir() << " (IPS_STARLOC_DIR)";
  auto rows = seq.rows;
  std::stable_sort(rows.begin(), rows.end(), [](const StarLocRow& a, const StarLocRow& b) { return a.t < b.t; });
  // The lab as a user would configure it: the 8 anchors, tags 1 and 2 as markers 1 and 2,
  // 10 cm ranges, up to 400 ranges a second from the one bridge.
  RangingConfig config;
  config.input.port = 5800;
  config.input.rate_per_source_hz = 400;
  config.sigma_m = 0.1;
  for (const auto& [id, pos] : seq.anchor_of) {
    config.anchors[static_cast<std::uint32_t>(id)].position = pos;
    config.input.anchors.insert(static_cast<std::uint32_t>(id));
  }
  for (std::uint32_t tag : {1u, 2u}) {
    config.tags[tag] = RangingTag::on_marker(static_cast<int>(tag));
    config.input.tags.insert(tag);
  }
  ASSERT_TRUE(config.track) << "the default";
  RangeAdmission admission(config.input, "ranging");
  RangeFixer fixer(config);
  std::map<int, std::optional<Eigen::Vector3d>> latest_position;
  std::map<int, std::uint32_t> firing_counter;
  std::vector<double> base_2d, base_3d, track_2d, track_3d;
  const std::int64_t realtime_offset = 1'790'000'000'000'000'000;  // a 2026 CLOCK_REALTIME
  constexpr std::uint32_t kBridge = 0x7f000001;                    // 127.0.0.1
  std::size_t end = 0;
  const auto to_ns = [](double t) { return static_cast<std::int64_t>(std::llround(t * 1e9)); };
  for (double t = 0.1; t < rows.back().t; t += 0.1) {
    for (; end < rows.size() && rows[end].t <= t; ++end) {
      const StarLocRow& r = rows[end];
      RangeFiring firing;
      firing.tag = static_cast<std::uint32_t>(r.tag);
      firing.firing = firing_counter[r.tag]++;
      firing.firing_realtime_ns = realtime_offset + to_ns(r.t);
      firing.entries.push_back({static_cast<std::uint32_t>(r.anchor), false, r.range, 0.0});
      const auto bytes = encode_range_firing(firing, "");
      const auto admitted = admission.admit(bytes, kBridge, 5000, to_ns(r.t), realtime_offset + to_ns(r.t));
      ASSERT_TRUE(admitted.has_value()) << "row at " << r.t << " s refused";
      const auto o = fixer.fix(*admitted, firing.firing_realtime_ns);
      if (o) {  // otherwise (a range gated out) the tag's last published position stands
        EXPECT_EQ(o->t_mono_ns, to_ns(r.t));
        EXPECT_EQ(o->id, r.tag);
        latest_position[r.tag] = o->p_world;
      }
    }
    for (int tag : {1, 2}) {
      std::map<int, const StarLocRow*> latest;
      for (std::size_t i = end; i-- > 0 && rows[i].t > t - 0.07;)
        if (rows[i].tag == tag && !latest.count(rows[i].anchor)) latest[rows[i].anchor] = &rows[i];
      if (latest.size() < 4 || !latest_position[tag]) continue;
      std::vector<RangeToAnchor> ranges;
      const StarLocRow* last = nullptr;
      for (const auto& [anchor, r] : latest) {
        ranges.push_back({seq.anchor_of.at(anchor), r->range, 0.1});
        if (!last || r->t > last->t) last = r;
      }
      RangeSolveOptions plain;
      plain.robust_sigmas = 0;
      plain.reject_sigmas = 0;
      const RangeFix fix = fix_least_squares(ranges, plain);
      if (!fix.ok) continue;
      base_2d.push_back((fix.position - last->truth).head<2>().norm());
      base_3d.push_back((fix.position - last->truth).norm());
      const Eigen::Vector3d p = *latest_position[tag];
      track_2d.push_back((p - last->truth).head<2>().norm());
      track_3d.push_back((p - last->truth).norm());
    }
  }
  ASSERT_GT(base_2d.size(), 500u);
  std::printf(
      "STAR-loc loop-2d-fast_s2 raw ranges, %zu instants: baseline 2-D p50 %.1f p95 %.1f cm, 3-D p50 %.1f p95 %.1f "
      "cm; range tracker 2-D p50 %.1f p95 %.1f cm, 3-D p50 %.1f p95 %.1f cm\n",
      base_2d.size(), 100 * pct(base_2d, 0.5), 100 * pct(base_2d, 0.95), 100 * pct(base_3d, 0.5),
      100 * pct(base_3d, 0.95), 100 * pct(track_2d, 0.5), 100 * pct(track_2d, 0.95), 100 * pct(track_3d, 0.5),
      100 * pct(track_3d, 0.95));
  for (const RangeTrackSummary& track : fixer.tracks()) {
    std::printf("tag %u: %llu restarts; learnt biases (cm):", track.tag,
                static_cast<unsigned long long>(track.restarts));
    for (const auto& [anchor, b] : track.biases_m) std::printf(" %u:%+.1f", anchor, 100 * b);
    std::printf("\n");
  }
  for (const auto& [what, n] : fixer.counters().ranges)
    std::printf("ranges %s: %llu\n", what.c_str(), static_cast<unsigned long long>(n));
  EXPECT_EQ(admission.counters().accepted, end) << "every range replayed was taken";
  // Measured 2026-11-27: baseline 2-D p50 21.1 p95 80.5 cm, 3-D 82.5 / 168.6 cm; tracker 2-D
  // 12.4 / 29.2 cm, 3-D 58.5 / 107.9 cm (0.36x and 0.64x the baseline's p95). The issue asks
  // for >= 30 % better; the vertical is what the anchors' geometry leaves weakest.
  EXPECT_LT(pct(track_2d, 0.95), 0.7 * pct(base_2d, 0.95));
  EXPECT_LT(pct(track_3d, 0.95), 0.7 * pct(base_3d, 0.95));
}

}  // namespace
}  // namespace ips
