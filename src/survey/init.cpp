// The survey's initial guess: each view's marker pose by PnP (IPPE on the square), cameras
// chained through instants two of them saw, then the whole rig moved onto the references.
#include <algorithm>
#include <cmath>
#include <set>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "ips/core/error.h"
#include "survey/views.h"

namespace ips::survey::detail {
namespace {

/// x_dst = R x_src + t, least squares (Kabsch/Umeyama without scale).
void rigid_fit(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst, Eigen::Matrix3d& R,
               Eigen::Vector3d& t) {
  Eigen::Matrix3Xd a(3, src.size()), b(3, dst.size());
  for (std::size_t i = 0; i < src.size(); ++i) {
    a.col(static_cast<Eigen::Index>(i)) = src[i];
    b.col(static_cast<Eigen::Index>(i)) = dst[i];
  }
  const Eigen::Matrix4d T = Eigen::umeyama(a, b, false);
  R = T.topLeftCorner<3, 3>();
  t = T.topRightCorner<3, 1>();
}

/// The spread of the points across their second principal direction, metres: ~0 when
/// they lie on a line (a rigid fit is then free to turn about it).
double second_spread(const std::vector<Eigen::Vector3d>& p) {
  if (p.size() < 3) return 0.0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& x : p) mean += x / static_cast<double>(p.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& x : p) cov += (x - mean) * (x - mean).transpose() / static_cast<double>(p.size());
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov);
  return std::sqrt(svd.singularValues()[1]);
}

}  // namespace

std::array<Eigen::Vector3d, 4> marker_corners(double edge) {
  const double h = edge / 2;
  return {Eigen::Vector3d(-h, h, 0), Eigen::Vector3d(h, h, 0), Eigen::Vector3d(h, -h, 0), Eigen::Vector3d(-h, -h, 0)};
}

std::vector<Target> make_targets(const SurveyInput& input) {
  std::vector<Target> out;
  for (const Instant& in : input.instants) {
    Target t;
    t.id = in.id;
    const auto e = input.edge_length.find(in.id);
    t.edge = e == input.edge_length.end() ? 0.2 : e->second;
    for (std::size_t r = 0; r < input.references.size(); ++r)
      if (input.references[r].id == in.id) t.reference = static_cast<int>(r);
    const auto corners = marker_corners(t.edge);
    std::vector<cv::Point3d> obj;
    for (const auto& c : corners) obj.emplace_back(c.x(), c.y(), c.z());
    for (const StillPeriod& p : in.views) {
      View v;
      v.camera = p.camera;
      const CameraModel& model = input.cameras[static_cast<std::size_t>(p.camera)].intrinsics;
      std::vector<cv::Point2d> img;
      bool ok = true;
      for (int k = 0; k < 4; ++k) {
        const Point2 n = model.undistort(p.corners[static_cast<std::size_t>(k)]);
        ok = ok && std::isfinite(n.x) && std::isfinite(n.y);
        v.ray[static_cast<std::size_t>(k)] = Eigen::Vector3d(n.x, n.y, 1.0).normalized();
        img.emplace_back(n.x, n.y);
      }
      if (!ok) continue;
      cv::Mat rvec, tvec;
      if (!cv::solvePnP(obj, img, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), rvec, tvec, false, cv::SOLVEPNP_IPPE_SQUARE))
        continue;
      cv::Mat Rm;
      cv::Rodrigues(rvec, Rm);
      cv::cv2eigen(Rm, v.R_cm);
      v.t_cm = Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
      if (!(v.t_cm.z() > 0)) continue;
      t.views.push_back(v);
    }
    // A reference is one pose however many instants it was found in (a camera's still
    // period may break on a noisy frame): its views join one target, one per camera.
    if (t.reference >= 0) {
      auto same = std::find_if(out.begin(), out.end(), [&](const Target& o) { return o.reference == t.reference; });
      if (same != out.end()) {
        for (const View& v : t.views)
          if (std::none_of(same->views.begin(), same->views.end(), [&](const View& w) { return w.camera == v.camera; }))
            same->views.push_back(v);
        continue;
      }
    }
    // A wand instant only one camera saw links nothing; a reference seen once still anchors.
    if (t.views.size() >= 2 || (t.reference >= 0 && !t.views.empty())) out.push_back(std::move(t));
  }
  return out;
}

void initial_poses(const SurveyInput& input, const std::vector<Target>& targets, std::vector<Eigen::Matrix3d>& R_cw,
                   std::vector<Eigen::Vector3d>& centre) {
  const std::size_t nc = input.cameras.size();
  // In the frame of a root camera first: pose of each camera in it (x_root = Rr x_cam + tr).
  std::vector<Eigen::Matrix3d> Rr(nc, Eigen::Matrix3d::Identity());
  std::vector<Eigen::Vector3d> tr(nc, Eigen::Vector3d::Zero());
  std::vector<int> views_of(nc, 0);
  for (const auto& t : targets)
    for (const auto& v : t.views) ++views_of[static_cast<std::size_t>(v.camera)];
  for (std::size_t c = 0; c < nc; ++c)
    if (views_of[c] == 0)
      throw InputError("camera '" + input.cameras[c].name +
                       "' saw no still marker that another camera also saw still (walk the wand "
                       "through its view, pausing where a neighbouring camera sees it too)");
  const auto root = static_cast<std::size_t>(std::max_element(views_of.begin(), views_of.end()) - views_of.begin());
  std::set<std::size_t> placed{root};
  auto in_root = [&](const Target& t, Eigen::Vector3d& p) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int n = 0;
    for (const auto& v : t.views)
      if (placed.count(static_cast<std::size_t>(v.camera))) {
        sum += Rr[static_cast<std::size_t>(v.camera)] * v.t_cm + tr[static_cast<std::size_t>(v.camera)];
        ++n;
      }
    if (n > 0) p = sum / n;
    return n > 0;
  };
  while (placed.size() < nc) {
    std::size_t best = nc;
    std::vector<Eigen::Vector3d> best_src, best_dst;
    for (std::size_t c = 0; c < nc; ++c) {
      if (placed.count(c)) continue;
      std::vector<Eigen::Vector3d> src, dst;
      for (const auto& t : targets) {
        Eigen::Vector3d p;
        if (!in_root(t, p)) continue;
        for (const auto& v : t.views)
          if (static_cast<std::size_t>(v.camera) == c) {
            src.push_back(v.t_cm);
            dst.push_back(p);
          }
      }
      if (src.size() > best_src.size()) {
        best = c;
        best_src = src;
        best_dst = dst;
      }
    }
    if (best == nc || static_cast<int>(best_src.size()) < input.min_shared || second_spread(best_dst) < 0.05) {
      std::string names;
      for (std::size_t c = 0; c < nc; ++c)
        if (!placed.count(c)) names += (names.empty() ? "'" : ", '") + input.cameras[c].name + "'";
      throw InputError("camera(s) " + names + " not connected to the rest: they share " +
                       std::to_string(best_src.size()) + " still wand instant(s) with the others (need " +
                       std::to_string(input.min_shared) +
                       ", not all on one line); pause the wand more often where two cameras see it");
    }
    rigid_fit(best_src, best_dst, Rr[best], tr[best]);
    placed.insert(best);
  }
  // The root frame onto the world: the reference centres.
  std::vector<Eigen::Vector3d> src, dst;
  std::string seen;
  for (const auto& t : targets) {
    Eigen::Vector3d p;
    if (t.reference < 0 || !in_root(t, p)) continue;
    src.push_back(p);
    dst.push_back(input.references[static_cast<std::size_t>(t.reference)].position);
    seen += (seen.empty() ? "" : ", ") + std::to_string(t.id);
  }
  if (src.size() < 3 || second_spread(dst) < 0.1) {
    std::string listed;
    for (const auto& r : input.references) listed += (listed.empty() ? "" : ", ") + std::to_string(r.id);
    throw InputError("references: " + std::to_string(src.size()) + " of the listed markers (" + listed +
                     ") seen still by the cameras" + (seen.empty() ? "" : " (" + seen + ")") +
                     "; at least 3, not on one line, are needed to fix the origin and orientation");
  }
  Eigen::Matrix3d Rw;
  Eigen::Vector3d tw;
  rigid_fit(src, dst, Rw, tw);
  R_cw.assign(nc, Eigen::Matrix3d::Identity());
  centre.assign(nc, Eigen::Vector3d::Zero());
  for (std::size_t c = 0; c < nc; ++c) {
    const Eigen::Matrix3d R_wc = Rw * Rr[c];
    R_cw[c] = R_wc.transpose();
    centre[c] = Rw * tr[c] + tw;
  }
}

}  // namespace ips::survey::detail
