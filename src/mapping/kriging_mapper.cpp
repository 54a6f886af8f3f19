// `ki` / `kr`: kriging as in the DACE toolbox (Lophaven, Nielsen, Søndergaard 2002):
// inputs and outputs normalised to zero mean / unit std, first-order polynomial trend
// (regpoly1), Gaussian correlation exp(-sum_k theta_k d_k^2) with one theta per input
// dimension, theta by maximum likelihood. Each output coordinate is its own process
// (see kJointOutputs).
//  - ki (interpolation): DACE's tiny diagonal regulariser (10 + m) * eps only; the predictor
//    passes through the training points.
//  - kr (regression): a homogeneous nugget 10^e on the correlation diagonal, e estimated by
//    maximum likelihood together with theta; the predictor smooths noisy points.
// The likelihood is maximised with NLopt BOBYQA in log10 space within bounds, from a fixed
// set of starts (deterministic).
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <nlohmann/json.hpp>
#include <nlopt.hpp>

#include "ips/core/error.h"
#include "mapping/json_params.h"
#include "mapping/mappers.h"

namespace ips::mapping {
namespace {

/// log10 theta bounds, in normalised input units (unit std): 1e-3 is an almost linear
/// field, 1e2 a correlation length of 0.1 std.
constexpr double kLogThetaLo = -3.0, kLogThetaHi = 2.0;
/// log10 nugget bounds for kr (relative to the process variance).
constexpr double kLogNuggetLo = -8.0, kLogNuggetHi = 0.0;
/// Objective evaluations per start (3-4 parameters; BOBYQA converges in far fewer).
constexpr int kMaxEvals = 150;
/// Convergence: absolute step in log10 units.
constexpr double kXtol = 1e-4;

constexpr int kTrend = 4;
/// true: one theta for x, y and z together (DACE called with a 3-column Y); false: each
/// output coordinate its own theta. Cross-validation on the published train40 favoured false
/// (e.g. 10-fold 3-D mean for ki on white 3.15 cm vs 4.07 cm joint).
constexpr bool kJointOutputs = false;  // 1, s1, s2, s3

struct Problem {
  const Eigen::MatrixXd* S = nullptr;  // m x 3, normalised inputs
  std::array<Eigen::MatrixXd, 3> D2;   // squared differences per dimension
  Eigen::MatrixXd F;                   // m x 4 trend regressors
  Eigen::MatrixXd Y;                   // normalised outputs fitted together (m x q)
  bool regression = false;
  double min_nugget = 0.0;
};

struct Solution {
  double objective = std::numeric_limits<double>::infinity();
  Eigen::MatrixXd beta, gamma;  // 4 x q, m x q
};

/// DACE's objective sigma^2 * det(R)^(1/m) (returned as its log), optionally the solution.
double objective(const Problem& pb, const double* x, Solution* out) {
  const Eigen::Index m = pb.Y.rows();
  const double th0 = std::pow(10.0, x[0]), th1 = std::pow(10.0, x[1]), th2 = std::pow(10.0, x[2]);
  const double nugget = pb.regression ? std::pow(10.0, x[3]) + pb.min_nugget : pb.min_nugget;
  Eigen::MatrixXd R = (-(th0 * pb.D2[0] + th1 * pb.D2[1] + th2 * pb.D2[2])).array().exp();
  R.diagonal().array() += nugget;
  const Eigen::LLT<Eigen::MatrixXd> llt(R);
  if (llt.info() != Eigen::Success) return 1e300;
  const Eigen::MatrixXd Ft = llt.matrixL().solve(pb.F);
  const Eigen::MatrixXd Yt = llt.matrixL().solve(pb.Y);
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(Ft);
  const Eigen::MatrixXd beta = qr.solve(Yt);
  const Eigen::MatrixXd rho = Yt - Ft * beta;
  const double sigma2 = rho.squaredNorm() / static_cast<double>(m);
  const double log_det = 2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
  const double obj = std::log(std::max(sigma2, 1e-300)) + log_det / static_cast<double>(m);
  if (!std::isfinite(obj)) return 1e300;
  if (out != nullptr) {
    out->objective = obj;
    out->beta = beta;
    out->gamma = llt.matrixU().solve(rho);  // R^-1 (y - F beta) = L^-T rho
  }
  return obj;
}

struct Tracker {
  const Problem* pb;
  double best = std::numeric_limits<double>::infinity();
  std::vector<double> best_x;
};

double nlopt_objective(unsigned n, const double* x, double*, void* data) {
  auto* t = static_cast<Tracker*>(data);
  const double v = objective(*t->pb, x, nullptr);
  if (v < t->best) {
    t->best = v;
    t->best_x.assign(x, x + n);
  }
  return v;
}

class KrigingMapper final : public Mapper {
 public:
  explicit KrigingMapper(bool regression) : regression_(regression) {}

  std::string method() const override { return regression_ ? "kr" : "ki"; }
  std::size_t min_points() const override { return 6; }

  void fit(std::span<const Eigen::Vector3d> cam, std::span<const Eigen::Vector3d> world, const FitOptions&) override {
    check_fit_input(*this, cam, world);
    const auto m = static_cast<Eigen::Index>(cam.size());
    Eigen::MatrixXd X(m, 3), Y(m, 3);
    for (Eigen::Index i = 0; i < m; ++i) {
      X.row(i) = cam[static_cast<std::size_t>(i)].transpose();
      Y.row(i) = world[static_cast<std::size_t>(i)].transpose();
    }
    auto moments = [m](const Eigen::MatrixXd& A, Eigen::Vector3d& mean, Eigen::Vector3d& sd) {
      mean = A.colwise().mean().transpose();
      for (int k = 0; k < 3; ++k) {
        const double v = (A.col(k).array() - mean[k]).square().sum() / static_cast<double>(m - 1);
        sd[k] = v > 0.0 ? std::sqrt(v) : 1.0;  // DACE: a constant column keeps scale 1
      }
    };
    moments(X, x_mean_, x_std_);
    moments(Y, y_mean_, y_std_);
    S_ = (X.rowwise() - x_mean_.transpose()).array().rowwise() / x_std_.transpose().array();
    // Coincident training inputs make R singular for ki.
    for (Eigen::Index i = 0; i < m; ++i)
      for (Eigen::Index j = i + 1; j < m; ++j)
        if ((S_.row(i) - S_.row(j)).squaredNorm() == 0.0)
          throw InputError(method() + ": two pairs have identical camera coordinates");

    Problem pb;
    pb.S = &S_;
    for (int k = 0; k < 3; ++k)
      pb.D2[static_cast<std::size_t>(k)] =
          (S_.col(k).replicate(1, m) - S_.col(k).transpose().replicate(m, 1)).array().square();
    pb.F.resize(m, kTrend);
    pb.F.col(0).setOnes();
    pb.F.rightCols(3) = S_;
    pb.regression = regression_;
    pb.min_nugget = (10.0 + static_cast<double>(m)) * std::numeric_limits<double>::epsilon();

    const unsigned dim = regression_ ? 4 : 3;
    std::vector<double> lo(dim, kLogThetaLo), hi(dim, kLogThetaHi);
    if (regression_) {
      lo[3] = kLogNuggetLo;
      hi[3] = kLogNuggetHi;
    }
    // Fixed multi-start: isotropic starts across the theta range (and, for kr, two nuggets).
    std::vector<std::vector<double>> starts;
    for (double t : {-1.5, 0.0, 1.0}) {
      if (regression_) {
        starts.push_back({t, t, t, -2.0});
        starts.push_back({t, t, t, -5.0});
      } else {
        starts.push_back({t, t, t});
      }
    }
    // Groups of outputs that share one theta: each output alone, or (DACE with a 3-column Y)
    // all three together.
    const std::vector<std::vector<int>> groups =
        kJointOutputs ? std::vector<std::vector<int>>{{0, 1, 2}} : std::vector<std::vector<int>>{{0}, {1}, {2}};
    for (const auto& group : groups) {
      pb.Y.resize(m, static_cast<Eigen::Index>(group.size()));
      for (std::size_t g = 0; g < group.size(); ++g) {
        const int k = group[g];
        pb.Y.col(static_cast<Eigen::Index>(g)) = (Y.col(k).array() - y_mean_[k]) / y_std_[k];
      }
      Tracker tracker{&pb, std::numeric_limits<double>::infinity(), {}};
      for (const auto& start : starts) {
        nlopt::opt opt(nlopt::LN_BOBYQA, dim);
        opt.set_lower_bounds(lo);
        opt.set_upper_bounds(hi);
        opt.set_min_objective(nlopt_objective, &tracker);
        opt.set_xtol_abs(kXtol);
        opt.set_maxeval(kMaxEvals);
        std::vector<double> x = start;
        double f = 0.0;
        try {
          opt.optimize(x, f);
        } catch (const std::exception&) {
          // Round-off or a failed Cholesky near a bound: the tracker keeps the best point seen.
        }
      }
      if (tracker.best_x.empty() || tracker.best >= 1e299)
        throw InputError(method() +
                         ": the correlation matrix is singular for every theta "
                         "(duplicate or degenerate points)");
      Solution sol;
      objective(pb, tracker.best_x.data(), &sol);
      for (std::size_t g = 0; g < group.size(); ++g) {
        auto& out = outputs_[static_cast<std::size_t>(group[g])];
        out.theta = Eigen::Vector3d(std::pow(10.0, tracker.best_x[0]), std::pow(10.0, tracker.best_x[1]),
                                    std::pow(10.0, tracker.best_x[2]));
        out.log10_nugget = regression_ ? tracker.best_x[3] : std::log10(pb.min_nugget);
        out.beta = sol.beta.col(static_cast<Eigen::Index>(g));
        out.gamma = sol.gamma.col(static_cast<Eigen::Index>(g));
      }
    }
  }

  Eigen::Vector3d predict(const Eigen::Vector3d& cam, double) const override {
    const Eigen::Vector3d s = (cam - x_mean_).cwiseQuotient(x_std_);
    Eigen::Vector3d out;
    const Eigen::Index m = S_.rows();
    for (int k = 0; k < 3; ++k) {
      const auto& o = outputs_[static_cast<std::size_t>(k)];
      double y = o.beta[0] + o.beta[1] * s[0] + o.beta[2] * s[1] + o.beta[3] * s[2];
      for (Eigen::Index i = 0; i < m; ++i) {
        const double d0 = s[0] - S_(i, 0), d1 = s[1] - S_(i, 1), d2 = s[2] - S_(i, 2);
        y += o.gamma[i] * std::exp(-(o.theta[0] * d0 * d0 + o.theta[1] * d1 * d1 + o.theta[2] * d2 * d2));
      }
      out[k] = y * y_std_[k] + y_mean_[k];
    }
    return out;
  }

  nlohmann::json to_json() const override {
    nlohmann::json outs = nlohmann::json::array();
    for (const auto& o : outputs_)
      outs.push_back({{"theta", to_json_array(o.theta)},
                      {"log10_nugget", o.log10_nugget},
                      {"beta", to_json_array(o.beta)},
                      {"gamma", to_json_array(o.gamma)}});
    return {{"trend", "regpoly1"},
            {"correlation", "gauss"},
            {"x_mean", to_json_array(x_mean_)},
            {"x_std", to_json_array(x_std_)},
            {"y_mean", to_json_array(y_mean_)},
            {"y_std", to_json_array(y_std_)},
            {"sites", to_json_rows(S_)},
            {"outputs", outs}};
  }

  void from_json(const nlohmann::json& p) override {
    if (get_string(p, "trend") != "regpoly1") throw InputError("parameter 'trend': unsupported");
    if (get_string(p, "correlation") != "gauss") throw InputError("parameter 'correlation': unsupported");
    x_mean_ = get_vector(p, "x_mean", 3);
    x_std_ = get_vector(p, "x_std", 3);
    y_mean_ = get_vector(p, "y_mean", 3);
    y_std_ = get_vector(p, "y_std", 3);
    if ((x_std_.array() <= 0.0).any() || (y_std_.array() <= 0.0).any())
      throw InputError("parameter 'x_std'/'y_std': must be positive");
    S_ = get_rows(p, "sites", -1, 3);
    const auto& outs = member(p, "outputs");
    if (!outs.is_array() || outs.size() != 3) throw InputError("parameter 'outputs': expected 3 outputs (x, y, z)");
    for (std::size_t k = 0; k < 3; ++k) {
      const auto& o = outs[k];
      auto& dst = outputs_[k];
      try {
        dst.theta = get_vector(o, "theta", 3);
        dst.log10_nugget = get_number(o, "log10_nugget");
        dst.beta = get_vector(o, "beta", kTrend);
        dst.gamma = get_vector(o, "gamma", S_.rows());
      } catch (const InputError& e) {
        throw InputError("outputs[" + std::to_string(k) + "]: " + e.what());
      }
      if ((dst.theta.array() <= 0.0).any())
        throw InputError("outputs[" + std::to_string(k) + "]: parameter 'theta': must be positive");
    }
  }

 private:
  struct Output {
    Eigen::Vector3d theta = Eigen::Vector3d::Ones();
    double log10_nugget = 0.0;
    Eigen::VectorXd beta = Eigen::VectorXd::Zero(kTrend);
    Eigen::VectorXd gamma;
  };

  bool regression_;
  Eigen::Vector3d x_mean_ = Eigen::Vector3d::Zero(), x_std_ = Eigen::Vector3d::Ones();
  Eigen::Vector3d y_mean_ = Eigen::Vector3d::Zero(), y_std_ = Eigen::Vector3d::Ones();
  Eigen::MatrixXd S_;
  std::array<Output, 3> outputs_{};
};

}  // namespace

std::unique_ptr<Mapper> make_kriging(bool regression) { return std::make_unique<KrigingMapper>(regression); }

}  // namespace ips::mapping
