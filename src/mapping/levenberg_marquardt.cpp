#include "mapping/levenberg_marquardt.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

namespace ips::mapping {

LmResult levenberg_marquardt(const ResidualFunction& f, Eigen::VectorXd p, const LmOptions& options) {
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  f(p, r, &J);
  double cost = 0.5 * r.squaredNorm();
  double mu = options.initial_damping;
  int it = 0;
  Eigen::VectorXd r_new;
  while (it < options.max_iterations && std::isfinite(cost)) {
    ++it;
    const Eigen::MatrixXd JtJ = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * r;
    if (g.lpNorm<Eigen::Infinity>() < 1e-15) break;
    Eigen::MatrixXd A = JtJ;
    if (options.scale_damping)
      A.diagonal() += mu * JtJ.diagonal().cwiseMax(1e-12);
    else
      A.diagonal().array() += mu;
    const Eigen::VectorXd step = A.ldlt().solve(-g);
    const Eigen::VectorXd p_new = p + step;
    f(p_new, r_new, nullptr);
    const double cost_new = 0.5 * r_new.squaredNorm();
    if (std::isfinite(cost_new) && cost_new < cost) {
      const double gain = (cost - cost_new) / std::max(cost, 1e-300);
      p = p_new;
      cost = cost_new;
      f(p, r, &J);
      mu = std::max(mu / 10.0, 1e-15);
      if (gain < options.relative_tolerance) break;
    } else {
      mu *= 10.0;
      if (mu > options.max_damping) break;
    }
  }
  return LmResult{p, cost, it};
}

Eigen::MatrixXd numeric_jacobian(const ResidualFunction& f, const Eigen::VectorXd& p, Eigen::Index residual_count) {
  Eigen::MatrixXd J(residual_count, p.size());
  Eigen::VectorXd q = p, rp, rm;
  for (Eigen::Index k = 0; k < p.size(); ++k) {
    const double h = 1e-6 * std::max(1.0, std::abs(p[k]));
    q[k] = p[k] + h;
    f(q, rp, nullptr);
    q[k] = p[k] - h;
    f(q, rm, nullptr);
    q[k] = p[k];
    J.col(k) = (rp - rm) / (2.0 * h);
  }
  return J;
}

}  // namespace ips::mapping
