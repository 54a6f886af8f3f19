#include "geometry/opencv_yaml.h"

#include <cctype>
#include <cmath>
#include <initializer_list>
#include <sstream>

#include <yaml-cpp/eventhandler.h>

#include "ips/core/error.h"

namespace ips::detail {
namespace {

// Counts documents without building them. YAML::LoadAll is not safe on untrusted text: yaml-cpp
// 0.7 does not consume a ',' at the start of a document, so LoadAll returns an endless series
// of null documents (about a gigabyte a second; the fuzz_intrinsics timeout
// tests/fuzz/intrinsics/opencv_timeout_after_guard.yaml). Asking for at most two is bounded.
class DocumentCounter : public YAML::EventHandler {
 public:
  YAML::Mark second;  // where a second document starts
  int documents = 0;
  void OnDocumentStart(const YAML::Mark& mark) override {
    if (++documents == 2) second = mark;
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t, const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}
};

std::string at(const std::string& where, const YAML::Node& node) {
  const YAML::Mark m = node.Mark();
  return m.is_null() ? where : where + ":" + std::to_string(m.line + 1);
}

// The first of `keys` present in `root` (OpenCV's samples and tools spell them differently).
YAML::Node first_of(const YAML::Node& root, std::initializer_list<const char*> keys, std::string& used) {
  for (const char* k : keys) {
    if (YAML::Node n = root[k]) {
      used = k;
      return n;
    }
  }
  used = *keys.begin();
  return YAML::Node(YAML::NodeType::Undefined);
}

double number(const std::string& where, const YAML::Node& n, const std::string& key) {
  double v = 0.0;
  bool ok = n.IsScalar();
  if (ok) {
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      ok = false;
    }
  }
  if (!ok) {
    // OpenCV writes NaN and infinity as .Nan, .Inf, -.Inf, spellings yaml-cpp does not convert.
    std::string low = n.IsScalar() ? n.Scalar() : std::string();
    for (char& c : low) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    const bool special = low == ".nan" || low == ".inf" || low == "-.inf" || low == "+.inf";
    throw InputError(at(where, n) + ": key '" + key + "': " + (special ? "non-finite value" : "not a number"));
  }
  if (!std::isfinite(v)) throw InputError(at(where, n) + ": key '" + key + "': non-finite value");
  return v;
}

int integer(const std::string& where, const YAML::Node& n, const std::string& key) {
  const double v = number(where, n, key);
  // Range first: converting a double outside int's range is undefined (found by fuzz_intrinsics).
  if (!(v > -1e9 && v < 1e9) || v != std::floor(v))
    throw InputError(at(where, n) + ": key '" + key + "': not an integer (or out of range)");
  return static_cast<int>(v);
}

// An !!opencv-matrix: rows x cols (at most 16 x 16, all K and D need), one channel of dt d
// (double), f (float: the values are rounded to float, as OpenCV's reader does) or i (int),
// rows*cols finite numbers in data. Row-major values.
std::vector<double> matrix(const std::string& where, const YAML::Node& root, std::initializer_list<const char*> keys,
                           std::string& key) {
  const YAML::Node n = first_of(root, keys, key);
  if (!n) throw InputError(where + ": missing key '" + key + "'");
  const std::string tag = n.Tag();
  if (!n.IsMap() || (tag != "?" && tag != "!" && tag != "tag:yaml.org,2002:opencv-matrix"))
    throw InputError(at(where, n) + ": key '" + key + "': expected an !!opencv-matrix (rows, cols, dt, data)");
  for (const char* part : {"rows", "cols", "dt", "data"}) {
    if (!n[part]) throw InputError(at(where, n) + ": key '" + key + "': missing '" + part + "'");
  }
  const int rows = integer(where, n["rows"], key + ".rows");
  const int cols = integer(where, n["cols"], key + ".cols");
  if (rows < 1 || cols < 1 || rows > 16 || cols > 16)
    throw InputError(at(where, n["rows"]) + ": key '" + key + "': " + std::to_string(rows) + " x " +
                     std::to_string(cols) + " is not a calibration matrix (1..16 rows and cols)");
  const YAML::Node dt = n["dt"];
  const std::string type = dt.IsScalar() ? dt.Scalar() : std::string();
  if (type != "d" && type != "f" && type != "i")
    throw InputError(at(where, dt) + ": key '" + key + ".dt': '" + type +
                     "' is not a one-channel number type (d, f or i)");
  const YAML::Node data = n["data"];
  if (!data.IsSequence()) throw InputError(at(where, data) + ": key '" + key + ".data': expected a list of numbers");
  if (data.size() != static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols))
    throw InputError(at(where, data) + ": key '" + key + "': rows x cols = " + std::to_string(rows * cols) +
                     " but data has " + std::to_string(data.size()) + " values");
  std::vector<double> out;
  for (const YAML::Node& v : data) {
    if (type == "i") {
      out.push_back(integer(where, v, key + ".data"));
    } else {
      const double x = number(where, v, key + ".data");
      if (type == "f" && !std::isfinite(static_cast<float>(x)))
        throw InputError(at(where, v) + ": key '" + key + ".data': out of range for dt f");
      out.push_back(type == "f" ? static_cast<double>(static_cast<float>(x)) : x);
    }
  }
  return out;
}

}  // namespace

YAML::Node parse_opencv_yaml(const std::string& where, const std::string& text) {
  std::string body = text;
  if (body.rfind("%YAML:", 0) == 0) {
    // Blank the directive line (not remove it), so yaml-cpp's line numbers are the file's.
    const auto end = body.find('\n');
    std::string directive = body.substr(0, end);
    while (!directive.empty() && (directive.back() == '\r' || directive.back() == ' ')) directive.pop_back();
    if (directive.size() < 9 || directive.compare(0, 8, "%YAML:1.") != 0 ||
        directive.find_first_not_of("0123456789", 8) != std::string::npos)
      throw InputError(where + ":1: expected the directive %YAML:1.0, got '" + directive.substr(0, 40) + "'");
    body.replace(0, end == std::string::npos ? body.size() : end, "");
  }
  try {
    std::istringstream in(body);
    YAML::Parser parser(in);
    DocumentCounter counter;
    while (counter.documents < 2 && parser.HandleNextDocument(counter)) {
    }
    if (counter.documents > 1)
      throw InputError(where + ":" + std::to_string(counter.second.line + 1) +
                       ": a second YAML document (an OpenCV calibration file is one mapping)");
    const YAML::Node root = YAML::Load(body);
    if (!root.IsMap())
      throw InputError(where + ": expected a YAML mapping of calibration keys (an OpenCV calibration file)");
    return root;
  } catch (const YAML::Exception& e) {
    throw InputError(where + ":" + std::to_string(e.mark.line + 1) + ": YAML error: " + e.msg);
  }
}

OpenCvIntrinsics read_opencv_intrinsics(const std::string& where, const YAML::Node& root) {
  OpenCvIntrinsics out;
  try {
    out.K = matrix(where, root, {"camera_matrix", "mtx", "K", "cameraMatrix"}, out.k_key);
    if (out.K.size() != 9)
      throw InputError(at(where, root[out.k_key]) + ": key '" + out.k_key + "': expected a 3x3 matrix, got " +
                       std::to_string(out.K.size()) + " values");
    out.D = matrix(where, root, {"distortion_coefficients", "dist", "D", "dist_coeffs", "distCoeffs"}, out.d_key);
    std::string key;
    auto read_size = [&](std::initializer_list<const char*> keys) {
      const YAML::Node n = first_of(root, keys, key);
      if (!n) throw InputError(where + ": missing key '" + key + "'");
      return integer(where, n, key);
    };
    out.width = read_size({"image_width", "img_width", "width"});
    out.height = read_size({"image_height", "img_height", "height"});
    if (const YAML::Node m = root["model"]) {
      if (!m.IsScalar()) throw InputError(at(where, m) + ": key 'model': not a string");
      out.model = m.Scalar();
    } else if (const YAML::Node f = root["fisheye_model"]) {
      out.fisheye = number(where, f, "fisheye_model") != 0.0;
    }
  } catch (const YAML::Exception& e) {
    // Navigation errors (a key of a non-map) are bad files too.
    throw InputError(where + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  return out;
}

}  // namespace ips::detail
