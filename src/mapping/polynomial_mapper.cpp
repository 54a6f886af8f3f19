// `pr`: full quadratic polynomial regression, 10 regressors
// 1, x, y, z, xy, xz, yz, x^2, y^2, z^2 per output, by column-pivoted Householder QR
// (numerically stable; the normal equations would square the condition number).
#include <Eigen/QR>
#include <nlohmann/json.hpp>

#include "ips/core/error.h"
#include "mapping/json_params.h"
#include "mapping/mappers.h"

namespace ips::mapping {
namespace {

constexpr int kTerms = 10;

Eigen::Matrix<double, kTerms, 1> regressors(const Eigen::Vector3d& p) {
  const double x = p.x(), y = p.y(), z = p.z();
  Eigen::Matrix<double, kTerms, 1> f;
  f << 1.0, x, y, z, x * y, x * z, y * z, x * x, y * y, z * z;
  return f;
}

class PolynomialMapper final : public Mapper {
 public:
  std::string method() const override { return "pr"; }
  std::size_t min_points() const override { return kTerms; }

  void fit(std::span<const Eigen::Vector3d> cam, std::span<const Eigen::Vector3d> world, const FitOptions&) override {
    check_fit_input(*this, cam, world);
    const auto m = static_cast<Eigen::Index>(cam.size());
    Eigen::MatrixXd A(m, kTerms), Y(m, 3);
    for (Eigen::Index i = 0; i < m; ++i) {
      A.row(i) = regressors(cam[static_cast<std::size_t>(i)]).transpose();
      Y.row(i) = world[static_cast<std::size_t>(i)].transpose();
    }
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
    if (qr.rank() < kTerms)
      throw InputError("pr: the points do not determine a quadratic (regressor rank " + std::to_string(qr.rank()) +
                       " < 10; they lie on a quadric or plane)");
    C_ = qr.solve(Y).transpose();
  }

  Eigen::Vector3d predict(const Eigen::Vector3d& cam, double) const override { return C_ * regressors(cam); }

  nlohmann::json to_json() const override {
    return {{"terms", "1,x,y,z,xy,xz,yz,x2,y2,z2"}, {"coefficients", to_json_rows(C_)}};
  }

  void from_json(const nlohmann::json& p) override {
    if (get_string(p, "terms") != "1,x,y,z,xy,xz,yz,x2,y2,z2")
      throw InputError("parameter 'terms': unknown regressor set");
    C_ = get_rows(p, "coefficients", 3, kTerms);
  }

 private:
  Eigen::Matrix<double, 3, kTerms> C_ = Eigen::Matrix<double, 3, kTerms>::Zero();
};

}  // namespace

std::unique_ptr<Mapper> make_polynomial() { return std::make_unique<PolynomialMapper>(); }

}  // namespace ips::mapping
