// The terminal-free parts of `ips collect`: typed entries, the two-distance position, the
// steadiness verdict, the pairs file (undo, resume) and the list of positions.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "ips/collect/collect.h"
#include "ips/core/error.h"
#include "ips/mapping/calib_data.h"

namespace ips::collect {
namespace {

Entry parse_ok(const std::string& line) {
  Entry e;
  std::string error;
  EXPECT_TRUE(parse_entry(line, EntryLimits{}, e, error)) << line << ": " << error;
  return e;
}

std::string parse_error(const std::string& line) {
  Entry e;
  std::string error;
  EXPECT_FALSE(parse_entry(line, EntryLimits{}, e, error)) << "accepted '" << line << "'";
  EXPECT_FALSE(error.empty());
  return error;
}

TEST(CollectEntry, PositionsCommandsAndDistances) {
  Entry e = parse_ok("  1.25 0.5\t0.1 ");
  EXPECT_EQ(e.kind, Entry::Kind::kPosition);
  EXPECT_EQ(e.position, Eigen::Vector3d(1.25, 0.5, 0.1));
  EXPECT_EQ(parse_ok("+1 -0.5 0").position, Eigen::Vector3d(1, -0.5, 0));
  EXPECT_EQ(parse_ok("").kind, Entry::Kind::kAccept);
  EXPECT_EQ(parse_ok("   ").kind, Entry::Kind::kAccept);
  EXPECT_EQ(parse_ok("u").kind, Entry::Kind::kUndo);
  EXPECT_EQ(parse_ok("undo").kind, Entry::Kind::kUndo);
  EXPECT_EQ(parse_ok("s").kind, Entry::Kind::kSkip);
  EXPECT_EQ(parse_ok("q").kind, Entry::Kind::kQuit);
  EXPECT_EQ(parse_ok("?").kind, Entry::Kind::kHelp);
  e = parse_ok("d 2.5 1.75 0.05 right");
  EXPECT_EQ(e.kind, Entry::Kind::kDistances);
  EXPECT_EQ(e.d_a, 2.5);
  EXPECT_EQ(e.d_b, 1.75);
  EXPECT_EQ(e.z, 0.05);
  EXPECT_EQ(e.side, Side::kRight);
  EXPECT_EQ(parse_ok("d 2.5 1.75 0").side, Side::kUnknown);
  EXPECT_EQ(parse_ok("d 2.5 1.75 0 l").side, Side::kLeft);
}

TEST(CollectEntry, TypingErrorsSayWhatWasExpected) {
  EXPECT_NE(parse_error("1,2").find("commas"), std::string::npos);
  EXPECT_NE(parse_error("1,2,0").find("commas"), std::string::npos);
  EXPECT_NE(parse_error("abc").find("'abc' is neither a position nor a command"), std::string::npos);
  EXPECT_NE(parse_error("1.5").find("3 numbers"), std::string::npos);
  EXPECT_NE(parse_error("1 2").find("3 numbers"), std::string::npos);
  EXPECT_NE(parse_error("1 2 3 4").find("3 numbers"), std::string::npos);
  EXPECT_NE(parse_error("1 x 0").find("'x' is not a number"), std::string::npos);
  EXPECT_NE(parse_error("1 2 0.1m").find("'0.1m' is not a number"), std::string::npos);
  EXPECT_NE(parse_error("nan 1 0").find("not a number"), std::string::npos);
  EXPECT_NE(parse_error("1 inf 0").find("not a number"), std::string::npos);
  EXPECT_NE(parse_error("1 2 5").find("out of range"), std::string::npos);
  EXPECT_NE(parse_error("1 2 -0.1").find("out of range"), std::string::npos);
  EXPECT_NE(parse_error("1e9 2 0").find("out of range"), std::string::npos);
  EXPECT_NE(parse_error("1e999 2 0").find("not a number"), std::string::npos);
  EXPECT_NE(parse_error("d 1 2").find("distances"), std::string::npos);
  EXPECT_NE(parse_error("d 0 2 0").find("> 0"), std::string::npos);
  EXPECT_NE(parse_error("d 1 2 0 up").find("left or right"), std::string::npos);
  EXPECT_NE(parse_error("d a 2 0").find("not a number"), std::string::npos);
  EXPECT_NE(parse_error("undo now").find("3 numbers"), std::string::npos);
}

TEST(CollectTwoDistances, BothSidesOfTheLineBetweenTheReferences) {
  // A (0, 0), B (4, 0); the point (3, 4) is 5 m from A and sqrt(17) m from B. Looking from A
  // towards B (+x), +y is on the left.
  const auto c = from_two_distances({0, 0}, {4, 0}, 5.0, std::sqrt(17.0));
  EXPECT_LT((c[0] - Eigen::Vector2d(3, 4)).norm(), 1e-12) << c[0].transpose();
  EXPECT_LT((c[1] - Eigen::Vector2d(3, -4)).norm(), 1e-12) << c[1].transpose();
  // The same point from references along y, B below A: now (3, 4) is on the left of A->B.
  const auto d = from_two_distances({0, 5}, {0, 1}, std::hypot(3.0, 1.0), std::hypot(3.0, 3.0));
  EXPECT_LT((d[0] - Eigen::Vector2d(3, 4)).norm(), 1e-12) << d[0].transpose();
  EXPECT_LT((d[1] - Eigen::Vector2d(-3, 4)).norm(), 1e-12) << d[1].transpose();
  // Distances that just miss each other by tape noise: the touching point.
  const auto t = from_two_distances({0, 0}, {4, 0}, 1.998, 1.998);
  EXPECT_LT((t[0] - Eigen::Vector2d(2, 0)).norm(), 1e-9);
  EXPECT_THROW(from_two_distances({0, 0}, {4, 0}, 1.0, 1.0), InputError);   // too short
  EXPECT_THROW(from_two_distances({0, 0}, {4, 0}, 10.0, 1.0), InputError);  // too different
  EXPECT_THROW(from_two_distances({1, 1}, {1, 1}, 1.0, 1.0), InputError);
}

TEST(CollectSteadiness, SeenMovedOrIntermittent) {
  SteadyOptions o;  // 80 % of the frames, 1 cm
  std::vector<Eigen::Vector3d> s;
  EXPECT_EQ(judge(s, 10, o).kind, CameraVerdict::Kind::kNotSeen);
  for (int i = 0; i < 8; ++i) s.emplace_back(0.1 + 0.001 * (i % 2), 0.2, 2.0);
  CameraVerdict v = judge(s, 10, o);
  EXPECT_EQ(v.kind, CameraVerdict::Kind::kSteady);
  EXPECT_EQ(v.seen, 8);
  EXPECT_NEAR(v.mean.x(), 0.1005, 1e-12);
  EXPECT_NEAR(v.spread, 0.0005, 1e-12);
  EXPECT_EQ(judge(s, 11, o).kind, CameraVerdict::Kind::kIntermittent);  // 8 < ceil(8.8)
  s.emplace_back(0.13, 0.2, 2.0);                                       // 3 cm off: moved
  v = judge(s, 10, o);
  EXPECT_EQ(v.kind, CameraVerdict::Kind::kMoved);
  EXPECT_NEAR(v.spread, 0.13 - (0.8 + 0.004 + 0.13) / 9, 1e-12);
}

// The cameras tell the side: red's pairs are an exact rigid map (world = R cam + t, a quarter
// turn about z plus a shift); where red sees the marker now maps onto one candidate.
TEST(CollectSide, TheCameraThatSeesItTellsTheSide) {
  Eigen::Matrix3d R;
  R << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const Eigen::Vector3d t(2.0, 1.0, 2.1);
  auto cam_of = [&](const Eigen::Vector3d& w) { return Eigen::Vector3d(R.transpose() * (w - t)); };
  PairsFile pairs;
  const std::array<Eigen::Vector2d, 2> candidates = from_two_distances({0, 0}, {4, 0}, 5.0, std::sqrt(17.0));
  std::string how;
  const std::vector<std::pair<std::string, Eigen::Vector3d>> seen_right = {{"red", cam_of({3, -4, 0})}};
  for (const Eigen::Vector3d& w : {Eigen::Vector3d(1, 1, 0), Eigen::Vector3d(3, 1, 0.1), Eigen::Vector3d(2, 3, 0),
                                   Eigen::Vector3d(0.5, 2.5, 0.2)}) {
    EXPECT_EQ(side_from_cameras(pairs, seen_right, candidates, how), -1);  // fewer than 4 pairs
    pairs.add({w, {{"red", cam_of(w)}, {"white", Eigen::Vector3d(0, 0, 2)}}});
  }
  EXPECT_EQ(side_from_cameras(pairs, seen_right, candidates, how), 1);
  EXPECT_NE(how.find("the right side: red puts it 0.00 m from it, 8.00 m from the other"), std::string::npos) << how;
  EXPECT_EQ(side_from_cameras(pairs, {{"red", cam_of({3, 4, 0})}}, candidates, how), 0);
  EXPECT_EQ(side_from_cameras(pairs, {{"black", cam_of({3, 4, 0})}}, candidates, how), -1);  // no pairs
}

TEST(CollectPairsFile, TextUndoAndResume) {
  PairsFile f;
  f.add({{1.0, 2.0, 0.1}, {{"red", {0.1, 0.2, 2.0}}, {"white", {-0.5, 0.25, 2.1}}}});
  f.add({{1.5, 2.0, 0.1}, {{"red", {0.3, 0.2, 2.0}}}});
  f.add({{1.5, 2.0, 0.1}, {{"red", {0.3, 0.2, 2.01}}}});  // the same point placed twice
  const std::string text = f.text();
  EXPECT_EQ(text.substr(0, text.find('\n')), "camera,xc,yc,zc,xw,yw,zw");
  // What `ips fit` reads.
  std::istringstream in(text);
  const CalibData data = parse_calib_csv(in, "t.csv");
  ASSERT_EQ(data.cameras.size(), 2u);
  EXPECT_EQ(data.find("red")->cam.size(), 3u);
  EXPECT_EQ(data.find("white")->world[0], Eigen::Vector3d(1.0, 2.0, 0.1));
  // Resumed: the same three placements (a camera seen twice starts a new one).
  PairsFile g = PairsFile::parse(text, "t.csv");
  ASSERT_EQ(g.placements().size(), 3u);
  EXPECT_EQ(g.placements()[0].cameras.size(), 2u);
  EXPECT_EQ(g.counts().at("red"), 3);
  EXPECT_EQ(g.text(), text);
  Placement removed;
  ASSERT_TRUE(g.undo(removed));
  EXPECT_EQ(removed.cameras[0].second.z(), 2.01);
  ASSERT_TRUE(g.undo(removed));
  ASSERT_TRUE(g.undo(removed));
  EXPECT_EQ(removed.cameras.size(), 2u);
  EXPECT_FALSE(g.undo(removed));
  EXPECT_EQ(g.text(), "camera,xc,yc,zc,xw,yw,zw\n");
  EXPECT_TRUE(PairsFile::parse(g.text(), "e.csv").placements().empty());
  EXPECT_TRUE(PairsFile::parse("", "e.csv").placements().empty());
  // Files it did not write, or broken ones, are refused with the place named.
  try {
    PairsFile::parse("camera,xc,yc,zc,xw,yw,zw,note\nred,0,0,2,1,1,0,x\n", "other.csv");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("other.csv"), std::string::npos) << e.what();
  }
  try {
    PairsFile::parse("camera,xc,yc,zc,xw,yw,zw\nred,0,0,2,1,abc,0\n", "bad.csv");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.csv:2"), std::string::npos) << e.what();
  }
}

TEST(CollectPointsFile, ListedPositions) {
  const auto p = parse_points_csv("name,xw,yw,zw\na,1,2,0.1\n\nb, 1.5 ,2.5,0\n", "p.csv");
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p[1], Eigen::Vector3d(1.5, 2.5, 0));
  for (const char* bad : {"x,y,z\n1,2,3\n", "xw,yw,zw\n1,2\n", "xw,yw,zw\n1,b,0\n", "xw,yw,zw\n", ""}) {
    EXPECT_THROW(parse_points_csv(bad, "p.csv"), InputError) << bad;
  }
  try {
    parse_points_csv("xw,yw,zw\n1,2,0\n1,b,0\n", "p.csv");
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("p.csv:3"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ips::collect
