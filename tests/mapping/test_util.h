// Shared helpers of the mapping tests: synthetic point sets with known truth.
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace ips::test {

/// Uniform points in the box [lo, hi] (deterministic for a seed).
inline std::vector<Eigen::Vector3d> random_points(std::size_t n, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                                                  std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<Eigen::Vector3d> pts(n);
  for (auto& p : pts)
    for (int k = 0; k < 3; ++k) p[k] = lo[k] + (hi[k] - lo[k]) * (static_cast<double>(rng()) / 4294967295.0);
  return pts;
}

/// Normal noise of standard deviation sigma (deterministic for a seed).
inline std::vector<double> gaussian_noise(std::size_t n, double sigma, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> dist(0.0, sigma);
  std::vector<double> out(n);
  for (auto& v : out) v = dist(rng);
  return out;
}

/// Path of the shipped published dataset.
inline std::string train40_path() { return std::string(IPS_TEST_DATA_DIR) + "/ou2023/train40.csv"; }

}  // namespace ips::test
