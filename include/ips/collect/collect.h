// The pieces of `ips collect` (live calibration pairs) that do not touch a terminal or a
// camera: what a typed line means, the world position from two tape distances, whether a
// camera saw the marker steadily, and the pairs file with undo and resume.
#pragma once

#include <array>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

namespace ips::collect {

// ---- Typed entries ------------------------------------------------------------------------

/// Which side of the line from reference A to reference B (looking from A towards B) the
/// marker is on; kUnknown = let the cameras tell.
enum class Side { kUnknown, kLeft, kRight };

struct Entry {
  enum class Kind {
    kPosition,   ///< "x y z": the world position, metres
    kDistances,  ///< "d DA DB Z [left|right]": floor distances to A and B, height Z
    kAccept,     ///< an empty line: the listed position (with --points)
    kUndo,       ///< "u" / "undo": remove the last placement
    kSkip,       ///< "s" / "skip": skip the listed position
    kQuit,       ///< "q" / "quit"
    kHelp,       ///< "?" / "h" / "help"
  };
  Kind kind = Kind::kHelp;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< kPosition
  double d_a = 0.0, d_b = 0.0, z = 0.0;                ///< kDistances
  Side side = Side::kUnknown;                          ///< kDistances
};

/// What a typed value may be: positions within +-max_abs_xy on the floor, heights in
/// [min_z, max_z], tape distances in (0, max_distance]; metres.
struct EntryLimits {
  double max_abs_xy = 100.0;
  double min_z = 0.0;
  double max_z = 3.0;
  double max_distance = 100.0;
};

/// Parses one typed line. Returns false with `error` saying what was expected (never
/// throws): commas ("1,2"), words ("abc"), a wrong count, NaN/inf and values outside
/// `limits` are errors.
bool parse_entry(std::string_view line, const EntryLimits& limits, Entry& out, std::string& error);

// ---- Two tape distances (the published Eq. 25 helper) ------------------------------------

/// The two floor points at horizontal distance d_a from a and d_b from b:
/// [0] left of the line a -> b (looking from a towards b), [1] right of it. Distances that
/// miss each other by up to `slack` (tape noise) are taken as touching; beyond that, throws
/// ips::InputError saying why.
std::array<Eigen::Vector2d, 2> from_two_distances(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double d_a,
                                                  double d_b, double slack = 0.01);

// ---- Steadiness of one camera's view over the frames of a placement ------------------------

struct SteadyOptions {
  double min_seen_fraction = 0.8;  ///< seen in at least this fraction of the frames
  double max_spread = 0.01;        ///< largest |p - mean| of a frame, metres; more = it moved
};

struct CameraVerdict {
  enum class Kind { kNotSeen, kIntermittent, kMoved, kSteady };
  Kind kind = Kind::kNotSeen;
  int seen = 0;                                    ///< frames in which the marker was located
  int frames = 0;                                  ///< frames looked at
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();  ///< mean camera coordinates, metres
  double spread = 0.0;                             ///< largest |p - mean| over the frames, metres
};

/// Judges one camera's samples (camera coordinates of the marker, one per frame it was
/// located in) out of `frames` frames.
CameraVerdict judge(const std::vector<Eigen::Vector3d>& samples, int frames, const SteadyOptions& options);

/// A list of world positions prepared in advance (CSV with columns xw,yw,zw in metres, any
/// others ignored). Throws ips::InputError naming `name`:line.
std::vector<Eigen::Vector3d> parse_points_csv(const std::string& text, const std::string& name);

// ---- The pairs file -----------------------------------------------------------------------

/// One placement of the marker: its world position and what each camera that saw it
/// steadily reported.
struct Placement {
  Eigen::Vector3d world = Eigen::Vector3d::Zero();
  std::vector<std::pair<std::string, Eigen::Vector3d>> cameras;  ///< (name, xc yc zc)
};

/// The CSV `ips fit` reads (camera,xc,yc,zc,xw,yw,zw), held as placements so that the last
/// one can be undone. A resumed file is split into placements at every row whose world
/// position differs from the previous row's or whose camera already appeared in the current
/// placement.
class PairsFile {
 public:
  /// Parses an existing file's text (validated by the calibration CSV loader; errors name
  /// `name`:line). Throws ips::InputError.
  static PairsFile parse(const std::string& text, const std::string& name);

  void add(Placement p) { placements_.push_back(std::move(p)); }
  /// Removes and returns the last placement; false if there is none.
  bool undo(Placement& removed);
  const std::vector<Placement>& placements() const { return placements_; }
  /// Rows per camera.
  std::map<std::string, int> counts() const;
  /// The file's text: the header and one row per camera of every placement.
  std::string text() const;

 private:
  std::vector<Placement> placements_;
};

/// Which of the two candidates of from_two_distances() the cameras put the marker at: each
/// camera in `seen` (name, its camera coordinates of the marker now) with >= 4 pairs in
/// `pairs` fits a rigid map (`rt`) of its pairs so far and predicts the marker's floor
/// position; the candidate nearer their mean prediction wins. Returns 0 (left), 1 (right) or
/// -1 if no camera can tell yet; `how` says which side, who told and how far the candidates
/// were from the prediction.
int side_from_cameras(const PairsFile& pairs, const std::vector<std::pair<std::string, Eigen::Vector3d>>& seen,
                      const std::array<Eigen::Vector2d, 2>& candidates, std::string& how);

}  // namespace ips::collect
