#include "ips/fusion/camera_lag.h"

namespace ips {

void CameraLag::add(std::int64_t t_capture_ns, std::int64_t t_fusion_ns) {
  const std::int64_t lag = t_fusion_ns - t_capture_ns;
  if (lag < 0) return;
  // A monotonic queue: a lag never matters again once a larger one arrives after it, so the
  // front is always the span's largest (amortised O(1) per frame).
  while (!lags_.empty() && lags_.back().second <= lag) lags_.pop_back();
  lags_.emplace_back(t_fusion_ns, lag);
  while (lags_.front().first < t_fusion_ns - kSpanNs) lags_.pop_front();
}

std::int64_t CameraLag::max_ns() const { return lags_.empty() ? 0 : lags_.front().second; }

}  // namespace ips
