// CameraModel: OpenCV fisheye (Kannala-Brandt, k1..k4) and pinhole (Brown-Conrady, 4/5/8
// coefficients, 12 with the thin-prism terms) intrinsics. project() is the closed-form model; undistort() inverts it
// with Newton iterations run to machine precision, so project(undistort(p)) == p to ~1e-12 px over the whole image
// (cv::fisheye::undistortPoints stops after 10 fixed-point steps, which leaves up to ~1e-3 px near the border of a
// 180-degree lens).
#include "ips/geometry/camera_model.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>
#include <opencv2/calib3d.hpp>

#include "geometry/opencv_yaml.h"
#include "ips/core/error.h"

namespace ips {
namespace {

constexpr int kMaxNewton = 50;
constexpr double kHalfPi = 1.5707963267948966;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void validate(const std::string& where, CameraModel::Kind kind, cv::Size size, const cv::Matx33d& K,
              const std::vector<double>& D) {
  if (size.width <= 0 || size.height <= 0) {
    throw InputError(where + ": key 'image_width'/'image_height': image size must be positive, got " +
                     std::to_string(size.width) + "x" + std::to_string(size.height));
  }
  for (int i = 0; i < 9; ++i) {
    if (!std::isfinite(K.val[i])) throw InputError(where + ": key 'K': non-finite value");
  }
  if (!(K(0, 0) > 0.0) || !(K(1, 1) > 0.0)) {
    throw InputError(where + ": key 'K': focal lengths fx, fy must be positive");
  }
  if (K(1, 0) != 0.0 || K(2, 0) != 0.0 || K(2, 1) != 0.0 || K(2, 2) != 1.0) {
    throw InputError(where + ": key 'K': must be upper triangular with K[2][2] = 1");
  }
  for (double d : D) {
    if (!std::isfinite(d)) throw InputError(where + ": key 'D': non-finite value");
  }
  if (kind == CameraModel::Kind::kFisheye && D.size() != 4) {
    throw InputError(where + ": key 'D': the fisheye model needs 4 coefficients (k1..k4), got " +
                     std::to_string(D.size()));
  }
  if (kind == CameraModel::Kind::kPinhole && D.size() != 4 && D.size() != 5 && D.size() != 8 && D.size() != 12) {
    throw InputError(where + ": key 'D': the pinhole model needs 4, 5, 8 or 12 coefficients, got " +
                     std::to_string(D.size()));
  }
}

CameraModel::Kind parse_kind(const std::string& where, const std::string& model) {
  if (model == "fisheye") return CameraModel::Kind::kFisheye;
  if (model == "pinhole") return CameraModel::Kind::kPinhole;
  throw InputError(where + ": key 'model': unknown camera model '" + model + "' (expected fisheye or pinhole)");
}

// --- the ipsd YAML form -------------------------------------------------------------
std::vector<double> yaml_numbers(const std::string& where, const YAML::Node& root, const char* key) {
  const YAML::Node node = root[key];
  if (!node) throw InputError(where + ": missing key '" + key + "'");
  if (!node.IsSequence()) throw InputError(where + ": key '" + key + "': expected a list of numbers");
  std::vector<double> out;
  for (const auto& v : node) {
    try {
      out.push_back(v.as<double>());
    } catch (const YAML::Exception&) {
      throw InputError(where + ": key '" + key + "': not a number");
    }
  }
  return out;
}

int yaml_int(const std::string& where, const YAML::Node& root, const char* key) {
  const YAML::Node node = root[key];
  if (!node) throw InputError(where + ": missing key '" + key + "'");
  try {
    return node.as<int>();
  } catch (const YAML::Exception&) {
    throw InputError(where + ": key '" + key + "': not an integer");
  }
}

CameraModel load_ipsd_yaml(const std::string& where, const YAML::Node& root) {
  std::string model;
  try {
    model = root["model"] ? root["model"].as<std::string>() : std::string();
  } catch (const YAML::Exception&) {
    throw InputError(where + ": key 'model': not a string");
  }
  if (model.empty()) throw InputError(where + ": missing key 'model' (fisheye or pinhole)");
  const CameraModel::Kind kind = parse_kind(where, model);
  const int w = yaml_int(where, root, "image_width");
  const int h = yaml_int(where, root, "image_height");
  const std::vector<double> k = yaml_numbers(where, root, "K");
  if (k.size() != 9) {
    throw InputError(where + ": key 'K': expected 9 values (row-major 3x3), got " + std::to_string(k.size()));
  }
  const std::vector<double> d = yaml_numbers(where, root, "D");
  cv::Matx33d K;
  for (int i = 0; i < 9; ++i) K.val[i] = k[static_cast<std::size_t>(i)];
  validate(where, kind, {w, h}, K, d);
  return CameraModel(kind, {w, h}, K, d);
}

// validate() says 'K' and 'D': name the keys as they appear in an OpenCV file instead.
std::string rename_keys(std::string msg, const std::string& k_key, const std::string& d_key) {
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"K", k_key}, {"D", d_key}}) {
    if (auto p = msg.find("'" + from + "'"); p != std::string::npos) msg.replace(p + 1, from.size(), to);
  }
  return msg;
}

// --- OpenCV FileStorage calibration files (calibration samples, calibrateCamera) -----
cv::FileNode first_of(const cv::FileStorage& fs, std::initializer_list<const char*> keys, std::string& used) {
  for (const char* k : keys) {
    cv::FileNode n = fs[k];
    if (!n.empty()) {
      used = k;
      return n;
    }
  }
  used = *keys.begin();
  return {};
}

CameraModel load_opencv_storage(const std::string& where, const std::filesystem::path& path) {
  cv::FileStorage fs;
  try {
    if (!fs.open(path.string(), cv::FileStorage::READ)) {
      throw InputError(where + ": not a readable YAML/XML/JSON calibration file");
    }
  } catch (const cv::Exception& e) {
    throw InputError(where + ": cannot parse as an OpenCV FileStorage file: " + e.msg);
  }
  std::string key;
  auto read_mat = [&](std::initializer_list<const char*> keys) {
    cv::FileNode n = first_of(fs, keys, key);
    if (n.empty()) throw InputError(where + ": missing key '" + key + "'");
    // OpenCV allocates rows x cols before it reads the data: check the shape against the data
    // first, or a typo in `rows` asks for gigabytes (found by fuzz_intrinsics).
    if (n.isMap()) {
      const cv::FileNode r = n["rows"], c = n["cols"], d = n["data"];
      const bool ok = r.isInt() && c.isInt() && static_cast<int>(r) >= 1 && static_cast<int>(c) >= 1 &&
                      static_cast<int>(r) <= 16 && static_cast<int>(c) <= 16 && d.isSeq() &&
                      d.size() == static_cast<std::size_t>(static_cast<int>(r) * static_cast<int>(c));
      if (!ok)
        throw InputError(where + ": key '" + key + "': not a matrix (rows x cols, at most 16 x 16, must match data)");
    }
    cv::Mat m;
    try {
      n >> m;
    } catch (const cv::Exception&) {
      throw InputError(where + ": key '" + key + "': not a matrix");
    }
    if (m.empty()) throw InputError(where + ": key '" + key + "': not a matrix");
    m.convertTo(m, CV_64F);
    return std::pair<cv::Mat, std::string>(m.reshape(1, 1), key);
  };
  auto read_int = [&](std::initializer_list<const char*> keys) {
    cv::FileNode n = first_of(fs, keys, key);
    if (n.empty() || !(n.isInt() || n.isReal())) {
      throw InputError(where + ": missing or non-numeric key '" + key + "'");
    }
    // Range first: converting a double outside int's range is undefined (found by fuzz_intrinsics).
    const double v = n.real();
    if (!(v > -1e9 && v < 1e9)) throw InputError(where + ": key '" + key + "': out of range");
    return static_cast<int>(v);
  };
  const auto [kmat, kkey] = read_mat({"camera_matrix", "mtx", "K", "cameraMatrix"});
  if (kmat.total() != 9) {
    throw InputError(where + ": key '" + kkey + "': expected a 3x3 matrix, got " + std::to_string(kmat.total()) +
                     " values");
  }
  const auto [dmat, dkey] = read_mat({"distortion_coefficients", "dist", "D", "dist_coeffs", "distCoeffs"});
  const int w = read_int({"image_width", "img_width", "width"});
  const int h = read_int({"image_height", "img_height", "height"});

  // The model: an explicit `model` string, else the calibration sample's `fisheye_model`
  // flag, else pinhole (what cv::calibrateCamera produces).
  CameraModel::Kind kind = CameraModel::Kind::kPinhole;
  if (cv::FileNode m = fs["model"]; !m.empty()) {
    if (!m.isString()) throw InputError(where + ": key 'model': not a string");
    kind = parse_kind(where, m.string());
  } else if (cv::FileNode f = fs["fisheye_model"]; !f.empty()) {
    kind = f.real() != 0.0 ? CameraModel::Kind::kFisheye : CameraModel::Kind::kPinhole;
  }
  cv::Matx33d K;
  for (int i = 0; i < 9; ++i) K.val[i] = kmat.at<double>(0, i);
  std::vector<double> D(dmat.begin<double>(), dmat.end<double>());
  try {
    validate(where, kind, {w, h}, K, D);
  } catch (const InputError& e) {
    throw InputError(rename_keys(e.what(), kkey, dkey));
  }
  return CameraModel(kind, {w, h}, K, D);
}

// OpenCV's YAML form, parsed by yaml-cpp (geometry/opencv_yaml.h); the model's rules here.
CameraModel load_opencv_yaml(const std::string& where, const YAML::Node& root) {
  const detail::OpenCvIntrinsics raw = detail::read_opencv_intrinsics(where, root);
  CameraModel::Kind kind = raw.fisheye ? CameraModel::Kind::kFisheye : CameraModel::Kind::kPinhole;
  if (!raw.model.empty()) kind = parse_kind(where, raw.model);
  cv::Matx33d K;
  for (int i = 0; i < 9; ++i) K.val[i] = raw.K[static_cast<std::size_t>(i)];
  try {
    validate(where, kind, {raw.width, raw.height}, K, raw.D);
  } catch (const InputError& e) {
    throw InputError(rename_keys(e.what(), raw.k_key, raw.d_key));
  }
  return CameraModel(kind, {raw.width, raw.height}, K, raw.D);
}

}  // namespace

CameraModel::CameraModel(Kind kind, cv::Size size, cv::Matx33d K, std::vector<double> D)
    : kind_(kind), size_(size), K_(K), D_(std::move(D)) {
  validate("CameraModel", kind_, size_, K_, D_);
  // Pinhole: 8 (rational) or 12 (rational + thin prism s1..s4) coefficients.
  D_.resize(kind_ == Kind::kPinhole ? (D_.size() > 8 ? 12 : 8) : 4, 0.0);
  if (kind_ == Kind::kFisheye) {
    // theta_d(theta) is invertible only while it increases; a fitted polynomial often turns
    // back before 90 degrees (the shipped "black" lens at 71 degrees), and pixels beyond
    // its maximum (the extreme image corners) have no ray in the model.
    const double step = 1e-4;
    max_theta_ = 0.0;
    for (double th = step; th < kHalfPi - 1e-9; th += step) {
      const double t2 = th * th;
      const double df = 1 + t2 * (3 * D_[0] + t2 * (5 * D_[1] + t2 * (7 * D_[2] + t2 * 9 * D_[3])));
      if (df <= 0.0) break;
      max_theta_ = th;
    }
    const double t2 = max_theta_ * max_theta_;
    max_theta_d_ = max_theta_ * (1 + t2 * (D_[0] + t2 * (D_[1] + t2 * (D_[2] + t2 * D_[3]))));
  }
}

CameraModel CameraModel::load(const std::filesystem::path& path) {
  const std::string where = path.string();
  std::ifstream in(path);
  if (!in) throw InputError(where + ": cannot open intrinsics file");
  std::stringstream text;
  text << in.rdbuf();
  const std::string s = text.str();
  // OpenCV's own files start with "%YAML:1.0" (which yaml-cpp rejects) or are XML/JSON. Only
  // XML and JSON go to OpenCV's FileStorage, which picks its parser by the first characters
  // ('<', '{', "%YAML"): its YAML parser never gets a file.
  const auto first = s.find_first_not_of(" \t\r\n");
  const char lead = first == std::string::npos ? '\0' : s[first];
  const bool opencv_form = lead == '<' || (lead == '{' && path.extension() == ".json");
  // OpenCV throws cv::Exception for files it opens but cannot navigate (a top-level sequence,
  // a scalar where a map is expected): bad input, said as such (found by fuzz_intrinsics).
  auto opencv = [&] {
    try {
      return load_opencv_storage(where, path);
    } catch (const cv::Exception& e) {
      throw InputError(where + ": not an OpenCV calibration file (" + e.err + ")");
    }
  };
  // OpenCV's YAML form: read by yaml-cpp, never by OpenCV (see geometry/opencv_yaml.h).
  if (s.rfind("%YAML:", 0) == 0) return load_opencv_yaml(where, detail::parse_opencv_yaml(where, s));
  if (opencv_form) return opencv();
  YAML::Node root;
  try {
    root = YAML::Load(s);
  } catch (const YAML::Exception& e) {
    throw InputError(where + ":" + std::to_string(e.mark.line + 1) + ": YAML error: " + e.msg);
  }
  if (!root.IsMap()) throw InputError(where + ": expected a YAML mapping of intrinsics keys");
  if (!root["K"] && (root["camera_matrix"] || root["mtx"])) return load_opencv_yaml(where, root);
  return load_ipsd_yaml(where, root);
}

Point2 CameraModel::project(Point2 n) const {
  double xd = 0.0;
  double yd = 0.0;
  if (kind_ == Kind::kFisheye) {
    const double r = std::hypot(n.x, n.y);
    const double th = std::atan(r);
    const double t2 = th * th;
    const double thd = th * (1 + t2 * (D_[0] + t2 * (D_[1] + t2 * (D_[2] + t2 * D_[3]))));
    const double s = r > 1e-15 ? thd / r : 1.0;
    xd = n.x * s;
    yd = n.y * s;
  } else {
    const double x = n.x;
    const double y = n.y;
    const double r2 = x * x + y * y;
    const double k1 = D_[0], k2 = D_[1], p1 = D_[2], p2 = D_[3], k3 = D_[4], k4 = D_[5], k5 = D_[6], k6 = D_[7];
    const double radial = (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)));
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
    if (D_.size() == 12) {  // thin prism
      xd += r2 * (D_[8] + r2 * D_[9]);
      yd += r2 * (D_[10] + r2 * D_[11]);
    }
  }
  return {K_(0, 0) * xd + K_(0, 1) * yd + K_(0, 2), K_(1, 1) * yd + K_(1, 2)};
}

Point2 CameraModel::undistort(Point2 px) const {
  const double yd = (px.y - K_(1, 2)) / K_(1, 1);
  const double xd = (px.x - K_(0, 2) - K_(0, 1) * yd) / K_(0, 0);
  if (kind_ == Kind::kFisheye) {
    // Solve theta_d = theta (1 + k1 t^2 + k2 t^4 + k3 t^6 + k4 t^8) for theta by Newton.
    const double thd = std::hypot(xd, yd);
    if (thd < 1e-15) return {xd, yd};
    if (thd > max_theta_d_) return {kNaN, kNaN};
    double th = thd;
    for (int i = 0; i < kMaxNewton; ++i) {
      const double t2 = th * th;
      const double f = th * (1 + t2 * (D_[0] + t2 * (D_[1] + t2 * (D_[2] + t2 * D_[3])))) - thd;
      const double df = 1 + t2 * (3 * D_[0] + t2 * (5 * D_[1] + t2 * (7 * D_[2] + t2 * 9 * D_[3])));
      const double step = f / df;
      th -= step;
      // Quadratic convergence: once a step is below 1e-9 rad the remaining error is ~1e-18.
      if (std::abs(step) < 1e-9) break;
    }
    if (!(th > 0.0 && th <= max_theta_ + 1e-6)) return {kNaN, kNaN};
    const double s = std::tan(th) / thd;
    return {xd * s, yd * s};
  }
  // Pinhole: OpenCV's iterative solution as the start, then Newton on the forward model
  // (numerical Jacobian; the residual, not the Jacobian, sets the final precision).
  std::vector<cv::Point2d> src{{px.x, px.y}}, dst;
  cv::undistortPoints(src, dst, cv::Mat(K_), cv::Mat(D_), cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 1e-12));
  Point2 n{dst[0].x, dst[0].y};
  if (!std::isfinite(n.x) || !std::isfinite(n.y)) n = {xd, yd};
  for (int i = 0; i < kMaxNewton; ++i) {
    const Point2 p = project(n);
    const double ex = p.x - px.x;
    const double ey = p.y - px.y;
    if (std::hypot(ex, ey) < 1e-12) break;
    const double h = 1e-7;
    const Point2 px_dx = project({n.x + h, n.y});
    const Point2 px_dy = project({n.x, n.y + h});
    const double a = (px_dx.x - p.x) / h, b = (px_dy.x - p.x) / h;
    const double c = (px_dx.y - p.y) / h, d = (px_dy.y - p.y) / h;
    const double det = a * d - b * c;
    if (std::abs(det) < 1e-300) break;
    n.x -= (d * ex - b * ey) / det;
    n.y -= (-c * ex + a * ey) / det;
  }
  const Point2 p = project(n);
  // No convergence: the pixel lies where the distortion polynomial folds over.
  if (!(std::hypot(p.x - px.x, p.y - px.y) < 1e-9)) return {kNaN, kNaN};
  return n;
}

void CameraModel::undistort(std::span<const Point2> px, std::span<Point2> norm) const {
  if (px.size() != norm.size()) throw std::invalid_argument("CameraModel::undistort: size mismatch");
  for (std::size_t i = 0; i < px.size(); ++i) norm[i] = undistort(px[i]);
}

}  // namespace ips
