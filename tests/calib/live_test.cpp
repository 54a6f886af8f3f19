// The live view selector on simulated frames: tilt directions against the true poses, and
// which frames it keeps (still, sharp, adding coverage or a wanted tilt).
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "calib_sim.h"
#include "ips/calib/live.h"

using ips::calib::Tilt;

TEST(ViewSelector, TiltDirectionMatchesTheTruePose) {
  const auto v = calib_test::make_views("pinhole", 16, 5);
  ips::calib::ViewSelector sel(*v.board, v.truth().size(), {});
  int checked = 0;
  for (std::size_t k = 0; k < v.views.size(); ++k) {
    const auto& R = v.views[k].pose.R;
    // Depth change along the board's x (right) and y (down the print) axes.
    const double dx = R(2, 0), dy = R(2, 1);
    if (std::hypot(dx, dy) < std::sin(25.0 * M_PI / 180) || std::abs(std::abs(dx) - std::abs(dy)) < 0.2)
      continue;  // not clearly tilted about one axis
    Tilt want = std::abs(dx) > std::abs(dy) ? (dx > 0 ? Tilt::kLeftNear : Tilt::kRightNear)
                                            : (dy > 0 ? Tilt::kTopNear : Tilt::kBottomNear);
    EXPECT_EQ(static_cast<int>(sel.tilt_of(v.observations[k])), static_cast<int>(want)) << "view " << k;
    ++checked;
  }
  EXPECT_GE(checked, 4);
}

TEST(ViewSelector, KeepsStillSharpNewViewsOnly) {
  const auto v = calib_test::make_views("pinhole", 6, 7);
  ips::calib::ViewSelector sel(*v.board, v.truth().size(), {});
  // First sight of a pose: not yet known to be still.
  EXPECT_FALSE(sel.offer(v.images[0], v.observations[0]).kept);
  // The same pose again: still, new -> kept.
  const auto d = sel.offer(v.images[0], v.observations[0]);
  EXPECT_TRUE(d.kept) << d.reason;
  // Again: still, but adds nothing (cells covered; the tilt direction is counted once per
  // view and needs 3, so offer it twice more to use up that wish).
  sel.offer(v.images[0], v.observations[0]);
  sel.offer(v.images[0], v.observations[0]);
  const auto again = sel.offer(v.images[0], v.observations[0]);
  EXPECT_FALSE(again.kept);
  EXPECT_NE(again.reason.find("adds nothing"), std::string::npos) << again.reason;
  // A blurred copy of a new pose, held still: rejected as blurred.
  cv::Mat blurred;
  cv::GaussianBlur(v.images[1], blurred, cv::Size(0, 0), 3.0);
  auto obs = ips::calib::detect_board(blurred, *v.board);
  sel.offer(blurred, obs);
  const auto b = sel.offer(blurred, obs);
  EXPECT_FALSE(b.kept);
  EXPECT_EQ(b.reason, "blurred");
  // Nothing in view.
  const cv::Mat empty(v.truth().size(), CV_8U, cv::Scalar(128));
  EXPECT_EQ(sel.offer(empty, ips::calib::detect_board(empty, *v.board)).reason, "no board");
  EXPECT_NE(sel.progress().find("views kept"), std::string::npos);
}
