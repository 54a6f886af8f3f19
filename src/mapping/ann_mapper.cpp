// `ann`: per output coordinate a 3-H-1 network (tanh hidden layer, linear output), inputs and
// outputs scaled to [-1, 1] (MATLAB's mapminmax, as the published models), trained with
// Levenberg–Marquardt (MATLAB's trainlm) from several random starts; the start with the
// least regularised training cost wins. Deterministic for a given seed.
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include <nlohmann/json.hpp>

#include "ips/core/error.h"
#include "mapping/json_params.h"
#include "mapping/levenberg_marquardt.h"
#include "mapping/mappers.h"

namespace ips::mapping {
namespace {

/// Hidden units per output network. 3 as in the published 3-3-1 models.
constexpr int kHidden = 3;
/// Random starts per output network; more starts make a bad local minimum less likely.
constexpr int kRestarts = 8;
/// LM iterations per start.
constexpr int kIterations = 300;
/// Weight decay (ridge on all weights, in normalised units): a small pull towards zero that
/// keeps 16 weights from chasing the ~0.5 cm measurement noise of 40 points. Cost term is
/// kDecay * |w|^2 next to the sum of squared normalised residuals.
constexpr double kDecay = 1e-3;

/// splitmix64: a tiny, well-mixed, platform-independent generator (std::uniform_real_distribution
/// is implementation-defined, so results would differ between standard libraries).
struct SplitMix64 {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  /// Uniform in [-1, 1).
  double symmetric() { return static_cast<double>(next() >> 11) * 0x1.0p-52 - 1.0; }
};

/// Parameters of one 3-H-1 network, layout: W1 (H x 3, row-major), b1 (H), w2 (H), b2.
int n_params(int h) { return 5 * h + 1; }

/// y = b2 + sum_j w2_j tanh(W1_j . x + b1_j); if J is given, fills dy/dparams into J.
double net_eval(const Eigen::VectorXd& p, int h, const Eigen::Vector3d& x, double* J) {
  double y = p[5 * h];  // b2
  for (int j = 0; j < h; ++j) {
    const double a = p[3 * j] * x[0] + p[3 * j + 1] * x[1] + p[3 * j + 2] * x[2] + p[3 * h + j];
    const double t = std::tanh(a);
    const double w2 = p[4 * h + j];
    y += w2 * t;
    if (J != nullptr) {
      const double d = w2 * (1.0 - t * t);
      J[3 * j] = d * x[0];
      J[3 * j + 1] = d * x[1];
      J[3 * j + 2] = d * x[2];
      J[3 * h + j] = d;
      J[4 * h + j] = t;
    }
  }
  if (J != nullptr) J[5 * h] = 1.0;
  return y;
}

class AnnMapper final : public Mapper {
 public:
  std::string method() const override { return "ann"; }
  std::size_t min_points() const override { return static_cast<std::size_t>(n_params(hidden_)); }

  void fit(std::span<const Eigen::Vector3d> cam, std::span<const Eigen::Vector3d> world,
           const FitOptions& options) override {
    check_fit_input(*this, cam, world);
    const std::size_t m = cam.size();
    Eigen::Vector3d lo = cam[0], hi = cam[0], ylo = world[0], yhi = world[0];
    for (std::size_t i = 0; i < m; ++i) {
      lo = lo.cwiseMin(cam[i]);
      hi = hi.cwiseMax(cam[i]);
      ylo = ylo.cwiseMin(world[i]);
      yhi = yhi.cwiseMax(world[i]);
    }
    for (int k = 0; k < 3; ++k) {
      in_offset_[k] = lo[k];
      in_scale_[k] = hi[k] - lo[k] > 1e-12 ? 2.0 / (hi[k] - lo[k]) : 1.0;
      out_offset_[k] = ylo[k];
      out_scale_[k] = yhi[k] - ylo[k] > 1e-12 ? 2.0 / (yhi[k] - ylo[k]) : 1.0;
    }
    std::vector<Eigen::Vector3d> xn(m);
    for (std::size_t i = 0; i < m; ++i) xn[i] = normalise_in(cam[i]);

    const int np = n_params(hidden_);
    for (int k = 0; k < 3; ++k) {
      Eigen::VectorXd yn(static_cast<Eigen::Index>(m));
      for (std::size_t i = 0; i < m; ++i)
        yn[static_cast<Eigen::Index>(i)] = (world[i][k] - out_offset_[k]) * out_scale_[k] - 1.0;
      const double decay = std::sqrt(kDecay);
      const ResidualFunction f = [&](const Eigen::VectorXd& p, Eigen::VectorXd& r, Eigen::MatrixXd* J) {
        r.resize(static_cast<Eigen::Index>(m) + np);
        if (J != nullptr) J->setZero(static_cast<Eigen::Index>(m) + np, np);
        std::array<double, 5 * 16 + 1> row{};
        for (std::size_t i = 0; i < m; ++i) {
          const auto ii = static_cast<Eigen::Index>(i);
          r[ii] = net_eval(p, hidden_, xn[i], J != nullptr ? row.data() : nullptr) - yn[ii];
          if (J != nullptr)
            for (int c = 0; c < np; ++c) (*J)(ii, c) = row[static_cast<std::size_t>(c)];
        }
        for (int c = 0; c < np; ++c) {
          r[static_cast<Eigen::Index>(m) + c] = decay * p[c];
          if (J != nullptr) (*J)(static_cast<Eigen::Index>(m) + c, c) = decay;
        }
      };
      SplitMix64 rng{options.seed * 0x100000001b3ULL + static_cast<std::uint64_t>(k) + 1};
      LmOptions lm;
      lm.max_iterations = kIterations;
      double best = std::numeric_limits<double>::infinity();
      for (int s = 0; s < kRestarts; ++s) {
        Eigen::VectorXd p0(np);
        for (int c = 0; c < np; ++c) p0[c] = rng.symmetric();
        const LmResult res = levenberg_marquardt(f, p0, lm);
        if (res.cost < best) {
          best = res.cost;
          weights_[static_cast<std::size_t>(k)] = res.params;
        }
      }
      if (!std::isfinite(best)) throw InputError("ann: training diverged");
    }
  }

  Eigen::Vector3d predict(const Eigen::Vector3d& cam, double) const override {
    const Eigen::Vector3d x = normalise_in(cam);
    Eigen::Vector3d out;
    for (int k = 0; k < 3; ++k) {
      const double yn = net_eval(weights_[static_cast<std::size_t>(k)], hidden_, x, nullptr);
      out[k] = (yn + 1.0) / out_scale_[k] + out_offset_[k];
    }
    return out;
  }

  nlohmann::json to_json() const override {
    nlohmann::json nets = nlohmann::json::array();
    for (const auto& w : weights_) nets.push_back(to_json_array(w));
    return {{"hidden", hidden_},
            {"layout", "W1(Hx3 row-major),b1(H),w2(H),b2"},
            {"in_offset", to_json_array(in_offset_)},
            {"in_scale", to_json_array(in_scale_)},
            {"out_offset", to_json_array(out_offset_)},
            {"out_scale", to_json_array(out_scale_)},
            {"networks", nets}};
  }

  void from_json(const nlohmann::json& p) override {
    hidden_ = get_int(p, "hidden", 1, 16);
    in_offset_ = get_vector(p, "in_offset", 3);
    in_scale_ = get_vector(p, "in_scale", 3);
    out_offset_ = get_vector(p, "out_offset", 3);
    out_scale_ = get_vector(p, "out_scale", 3);
    const auto& nets = member(p, "networks");
    if (!nets.is_array() || nets.size() != 3) throw InputError("parameter 'networks': expected 3 networks (x, y, z)");
    for (std::size_t k = 0; k < 3; ++k) {
      const nlohmann::json wrap = {{"networks[" + std::to_string(k) + "]", nets[k]}};
      weights_[k] = get_vector(wrap, "networks[" + std::to_string(k) + "]", n_params(hidden_));
    }
    for (int k = 0; k < 3; ++k)
      if (in_scale_[k] == 0.0 || out_scale_[k] == 0.0) throw InputError("parameter 'in_scale'/'out_scale': zero scale");
  }

 private:
  Eigen::Vector3d normalise_in(const Eigen::Vector3d& x) const {
    return ((x - in_offset_).cwiseProduct(in_scale_)).array() - 1.0;
  }

  int hidden_ = kHidden;
  Eigen::Vector3d in_offset_ = Eigen::Vector3d::Zero(), in_scale_ = Eigen::Vector3d::Ones();
  Eigen::Vector3d out_offset_ = Eigen::Vector3d::Zero(), out_scale_ = Eigen::Vector3d::Ones();
  std::array<Eigen::VectorXd, 3> weights_{Eigen::VectorXd::Zero(n_params(kHidden)),
                                          Eigen::VectorXd::Zero(n_params(kHidden)),
                                          Eigen::VectorXd::Zero(n_params(kHidden))};
};

}  // namespace

std::unique_ptr<Mapper> make_ann() { return std::make_unique<AnnMapper>(); }

}  // namespace ips::mapping
