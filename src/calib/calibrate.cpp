#include "ips/calib/calibrate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/core/error.h"

namespace ips::calib {
namespace {

constexpr double kRadToDeg = 57.29577951308232;

struct Fit {
  cv::Matx33d K;
  std::vector<double> D;
  std::vector<cv::Vec3d> rvecs, tvecs;
};

std::vector<cv::Point3d> object_points(const BoardObservation& o, const Board& board) {
  std::vector<cv::Point3d> out;
  for (int id : o.ids) out.push_back(board.corners()[static_cast<std::size_t>(id)]);
  return out;
}

// One OpenCV fit over the given views.
Fit fit(const std::vector<const BoardObservation*>& views, const Board& board, CameraModel::Kind kind, cv::Size size,
        bool thin_prism) {
  Fit f;
  const cv::TermCriteria crit(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, 1e-12);
  if (kind == CameraModel::Kind::kFisheye) {
    std::vector<cv::Mat> obj, img;
    for (const auto* v : views) {
      const auto o = object_points(*v, board);
      obj.push_back(cv::Mat(o, true).reshape(3, static_cast<int>(o.size())));
      img.push_back(cv::Mat(v->px, true).reshape(2, static_cast<int>(v->px.size())));
    }
    cv::Vec4d D;
    const int flags = cv::fisheye::CALIB_RECOMPUTE_EXTRINSIC | cv::fisheye::CALIB_FIX_SKEW;
    cv::fisheye::calibrate(obj, img, size, f.K, D, f.rvecs, f.tvecs, flags, crit);
    f.D.assign(D.val, D.val + 4);
  } else {
    std::vector<std::vector<cv::Point3f>> obj;
    std::vector<std::vector<cv::Point2f>> img;
    for (const auto* v : views) {
      std::vector<cv::Point3f> o;
      for (const auto& p : object_points(*v, board))
        o.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y), 0.0f);
      std::vector<cv::Point2f> i;
      for (const auto& p : v->px) i.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
      obj.push_back(o);
      img.push_back(i);
    }
    cv::Mat K, D;
    std::vector<cv::Mat> rv, tv;
    const int flags = cv::CALIB_RATIONAL_MODEL | (thin_prism ? cv::CALIB_THIN_PRISM_MODEL : 0);
    cv::calibrateCamera(obj, img, size, K, D, rv, tv, flags, crit);
    f.K = cv::Matx33d(K);
    f.D.assign(D.begin<double>(), D.end<double>());
    f.D.resize(thin_prism ? 12 : 8, 0.0);
    for (std::size_t i = 0; i < rv.size(); ++i) {
      f.rvecs.emplace_back(rv[i]);
      f.tvecs.emplace_back(tv[i]);
    }
  }
  return f;
}

std::vector<cv::Point2d> project(const CameraModel& model, const std::vector<cv::Point3d>& obj, const cv::Vec3d& rvec,
                                 const cv::Vec3d& tvec) {
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  std::vector<cv::Point2d> out;
  for (const auto& p : obj) {
    const cv::Vec3d c = R * cv::Vec3d(p.x, p.y, p.z) + tvec;
    const Point2 px = model.project({c[0] / c[2], c[1] / c[2]});
    out.emplace_back(px.x, px.y);
  }
  return out;
}

// Residuals of one view under `model` with the given pose.
void residuals(ViewResult& v, const BoardObservation& o, const Board& board, const CameraModel& model) {
  const auto proj = project(model, object_points(o, board), v.rvec, v.tvec);
  v.px = o.px;
  v.residual.clear();
  double ss = 0.0;
  for (std::size_t i = 0; i < proj.size(); ++i) {
    const cv::Point2d r = o.px[i] - proj[i];
    v.residual.push_back(r);
    ss += r.dot(r);
  }
  v.rms = proj.empty() ? 0.0 : std::sqrt(ss / static_cast<double>(proj.size()));
}

// Pose of a view not in the fit (a dropped outlier), for its residuals in the report.
bool pose_of(const BoardObservation& o, const Board& board, const CameraModel& model, cv::Vec3d& rvec,
             cv::Vec3d& tvec) {
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> norm;
  const auto all = object_points(o, board);
  for (std::size_t i = 0; i < o.px.size(); ++i) {
    const Point2 n = model.undistort({o.px[i].x, o.px[i].y});
    if (!std::isfinite(n.x)) continue;
    obj.push_back(all[i]);
    norm.emplace_back(n.x, n.y);
  }
  if (obj.size() < 6) return false;
  try {
    return cv::solvePnP(obj, norm, cv::Matx33d::eye(), cv::noArray(), rvec, tvec);
  } catch (const cv::Exception&) {
    return false;  // degenerate (e.g. corners on one line): no residuals to show for it
  }
}

std::string usable_problem(const BoardObservation& o, int min_corners) {
  if (o.ids.empty()) return "no board found";
  if (static_cast<int>(o.ids.size()) < min_corners)
    return "only " + std::to_string(o.ids.size()) + " corners (need " + std::to_string(min_corners) + ")";
  // Corners on one line say nothing about the plane's tilt: check the spread of the pixels.
  cv::Mat pts(static_cast<int>(o.px.size()), 2, CV_64F);
  for (std::size_t i = 0; i < o.px.size(); ++i) {
    pts.at<double>(static_cast<int>(i), 0) = o.px[i].x;
    pts.at<double>(static_cast<int>(i), 1) = o.px[i].y;
  }
  cv::PCA pca(pts, cv::noArray(), cv::PCA::DATA_AS_ROW);
  const double l0 = pca.eigenvalues.at<double>(0), l1 = pca.eigenvalues.at<double>(1);
  if (!(l1 > 1e-3 * l0)) return "corners all on one line";
  return {};
}

}  // namespace

cv::Size coverage_grid(cv::Size image) {
  const int gx = 16;
  const int gy = std::max(1, static_cast<int>(std::lround(gx * double(image.height) / image.width)));
  return {gx, gy};
}

CalibrationResult calibrate(const std::vector<BoardObservation>& input, const Board& board,
                            const CalibrationOptions& opt) {
  if (input.empty()) throw InputError("no images to calibrate from");
  // Corners found to be outliers are removed from this working copy between rounds.
  std::vector<BoardObservation> observations = input;
  const cv::Size size = observations.front().image_size;
  for (const auto& o : observations) {
    if (o.image_size != size) {
      throw InputError("images of different sizes: " + observations.front().name + " is " + std::to_string(size.width) +
                       "x" + std::to_string(size.height) + ", " + o.name + " is " + std::to_string(o.image_size.width) +
                       "x" + std::to_string(o.image_size.height));
    }
  }
  CalibrationResult res;
  res.views.resize(observations.size());
  std::vector<std::size_t> active;
  int with_board = 0;
  for (std::size_t i = 0; i < observations.size(); ++i) {
    res.views[i].name = observations[i].name;
    res.views[i].corners = static_cast<int>(observations[i].ids.size());
    with_board += observations[i].ids.empty() ? 0 : 1;
    res.views[i].why = usable_problem(observations[i], opt.min_corners);
    if (res.views[i].why.empty()) active.push_back(i);
  }
  if (with_board == 0) {
    throw InputError("no board (" + board.spec().str() + ") found in any of the " +
                     std::to_string(observations.size()) + " image(s)");
  }
  if (static_cast<int>(active.size()) < opt.min_views) {
    throw InputError("too few views: " + std::to_string(active.size()) + " of " + std::to_string(observations.size()) +
                     " image(s) show a usable board (at least " + std::to_string(opt.min_corners) + " corners), " +
                     std::to_string(opt.min_views) + " needed");
  }
  Fit f;
  for (int round = 0;; ++round) {
    std::vector<const BoardObservation*> views;
    for (std::size_t i : active) views.push_back(&observations[i]);
    try {
      f = fit(views, board, opt.kind, size, opt.thin_prism);
    } catch (const cv::Exception& e) {
      // cv::fisheye::calibrate's start (a homography per view from undistorted points with a
      // guessed focal length) fails on some views (assertion "norm_u1 > 0"); find one whose
      // removal lets the fit run, drop it by name, and go on.
      std::size_t culprit = active.size();
      for (std::size_t k = 0; k < active.size() && culprit == active.size(); ++k) {
        std::vector<const BoardObservation*> others;
        for (std::size_t j = 0; j < active.size(); ++j)
          if (j != k) others.push_back(&observations[active[j]]);
        try {
          (void)fit(others, board, opt.kind, size, opt.thin_prism);
          culprit = k;
        } catch (const cv::Exception&) {
        }
      }
      if (culprit == active.size() || static_cast<int>(active.size()) - 1 < opt.min_views) {
        throw InputError(std::string("the calibration did not converge (OpenCV: ") + e.err +
                         "); take views that show the board larger, flatter and nearer the centre");
      }
      res.views[active[culprit]].why = std::string("OpenCV's calibration fails with this view (") + e.err + ")";
      active.erase(active.begin() + static_cast<long>(culprit));
      --round;
      continue;
    }
    const CameraModel model(opt.kind, size, f.K, f.D);
    std::vector<double> typical;  // per view: median corner residual (one bad corner leaves it alone)
    double ss = 0.0;
    std::size_t n = 0;
    for (std::size_t k = 0; k < active.size(); ++k) {
      ViewResult& v = res.views[active[k]];
      v.rvec = f.rvecs[k];
      v.tvec = f.tvecs[k];
      residuals(v, observations[active[k]], board, model);
      std::vector<double> e;
      for (const auto& r : v.residual) e.push_back(std::sqrt(r.dot(r)));
      std::nth_element(e.begin(), e.begin() + static_cast<long>(e.size() / 2), e.end());
      typical.push_back(e.empty() ? 0.0 : e[e.size() / 2]);
      for (const auto& r : v.residual) ss += r.dot(r);
      n += v.residual.size();
    }
    if (!opt.drop_outliers || round >= 5) break;
    // Views far off the rest (a blurred or moved frame) go first, as a whole; then single
    // corners far off the fit (a corner refined onto the wrong feature, e.g. at the image
    // border).
    std::vector<double> sorted = typical;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
    const double median = sorted[sorted.size() / 2];
    const double limit = std::max(opt.outlier_factor * median, median + opt.outlier_floor_px);
    std::vector<std::size_t> keep;
    for (std::size_t k = 0; k < active.size(); ++k) {
      if (typical[k] > limit) {
        char why[200];
        std::snprintf(why, sizeof why,
                      "outlier: its corners are typically %.2f px off the fit, > %.2f px (the views' median %.2f px)",
                      typical[k], limit, median);
        res.views[active[k]].why = why;
      } else {
        keep.push_back(active[k]);
      }
    }
    if (keep.size() != active.size()) {
      if (static_cast<int>(keep.size()) < opt.min_views) {
        throw InputError("too few views: " + std::to_string(active.size() - keep.size()) + " of " +
                         std::to_string(active.size()) + " views are outliers, fewer than " +
                         std::to_string(opt.min_views) + " remain");
      }
      active = keep;
      continue;
    }
    const double corner_limit =
        std::max(opt.corner_outlier_factor * std::sqrt(ss / std::max<std::size_t>(1, n)), opt.corner_outlier_floor_px);
    int removed = 0;
    for (std::size_t k = 0; k < active.size(); ++k) {
      ViewResult& v = res.views[active[k]];
      BoardObservation& o = observations[active[k]];
      for (std::size_t i = v.residual.size(); i-- > 0;) {
        if (std::sqrt(v.residual[i].dot(v.residual[i])) <= corner_limit) continue;
        o.ids.erase(o.ids.begin() + static_cast<long>(i));
        o.px.erase(o.px.begin() + static_cast<long>(i));
        if (!o.window.empty()) o.window.erase(o.window.begin() + static_cast<long>(i));
        ++v.corners_dropped;
        ++removed;
      }
    }
    if (removed > 0) {
      std::vector<std::size_t> still;
      for (std::size_t i : active) {
        res.views[i].why = usable_problem(observations[i], opt.min_corners);
        if (res.views[i].why.empty()) still.push_back(i);
      }
      if (static_cast<int>(still.size()) < opt.min_views)
        throw InputError("too few views: after removing outlier corners, fewer than " + std::to_string(opt.min_views) +
                         " views remain usable");
      active = still;
      continue;
    }
    break;
  }
  res.model = CameraModel(opt.kind, size, f.K, f.D);
  double ss = 0.0;
  std::size_t n = 0;
  res.grid = coverage_grid(size);
  res.grid_counts.assign(static_cast<std::size_t>(res.grid.area()), 0);
  for (std::size_t i = 0; i < observations.size(); ++i) {
    ViewResult& v = res.views[i];
    v.used = std::find(active.begin(), active.end(), i) != active.end();
    if (!v.used) {
      if (!observations[i].ids.empty() && pose_of(observations[i], board, res.model, v.rvec, v.tvec)) {
        residuals(v, observations[i], board, res.model);
      }
      continue;
    }
    v.why.clear();
    ++res.used_views;
    for (std::size_t k = 0; k < v.residual.size(); ++k) {
      ss += v.residual[k].dot(v.residual[k]);
      ++n;
      const cv::Point2d& p = v.px[k];
      const int gx = std::clamp(static_cast<int>(p.x * res.grid.width / size.width), 0, res.grid.width - 1);
      const int gy = std::clamp(static_cast<int>(p.y * res.grid.height / size.height), 0, res.grid.height - 1);
      ++res.grid_counts[static_cast<std::size_t>(gy * res.grid.width + gx)];
      const Point2 nrm = res.model.undistort({p.x, p.y});
      if (!std::isfinite(nrm.x)) {
        ++res.corners_without_ray;
        continue;
      }
      res.max_field_deg = std::max(res.max_field_deg, std::atan(std::hypot(nrm.x, nrm.y)) * kRadToDeg);
    }
  }
  res.rms = n ? std::sqrt(ss / static_cast<double>(n)) : 0.0;
  res.coverage =
      static_cast<double>(std::count_if(res.grid_counts.begin(), res.grid_counts.end(), [](int c) { return c > 0; })) /
      static_cast<double>(res.grid.area());
  if (opt.kind == CameraModel::Kind::kFisheye && res.model.max_theta() < 1.5707963267948966 - 1e-3) {
    res.turn_back_deg = res.model.max_theta() * kRadToDeg;
    const double r = std::tan(res.model.max_theta());
    const Point2 edge = res.model.project({r, 0.0});
    res.turn_back_radius_px = edge.x - res.model.K()(0, 2);
  }
  return res;
}

CameraModel calibrate_opencv_plain(const std::vector<BoardObservation>& observations, const Board& board,
                                   CameraModel::Kind kind, int min_corners, bool thin_prism) {
  std::vector<const BoardObservation*> views;
  for (const auto& o : observations)
    if (usable_problem(o, min_corners).empty()) views.push_back(&o);
  if (views.empty()) throw InputError("no usable views");
  const Fit f = fit(views, board, kind, views.front()->image_size, thin_prism);
  return CameraModel(kind, views.front()->image_size, f.K, f.D);
}

ModelDifference compare_models(const CameraModel& truth, const CameraModel& estimate,
                               const std::vector<cv::Point2d>& points, double radius_px, int step) {
  cv::Mat mask(truth.size(), CV_8U, cv::Scalar(0));
  for (const auto& p : points)
    cv::circle(mask, cv::Point(static_cast<int>(std::lround(p.x)), static_cast<int>(std::lround(p.y))),
               static_cast<int>(radius_px), cv::Scalar(255), cv::FILLED);
  ModelDifference d;
  double ss = 0.0;
  for (int y = 0; y < mask.rows; y += step) {
    for (int x = 0; x < mask.cols; x += step) {
      if (!mask.at<std::uint8_t>(y, x)) continue;
      const Point2 n = truth.undistort({double(x), double(y)});
      if (!std::isfinite(n.x)) continue;
      const Point2 p = estimate.project(n);
      const double e = std::hypot(p.x - x, p.y - y);
      const double ef = std::isfinite(e) ? e : 1e9;
      if (ef > d.max_px) {
        d.max_px = ef;
        d.worst = {double(x), double(y)};
      }
      ss += e * e;
      ++d.pixels;
    }
  }
  d.rms_px = d.pixels ? std::sqrt(ss / d.pixels) : 0.0;
  return d;
}

}  // namespace ips::calib
