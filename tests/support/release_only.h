#pragma once
// Heavy end-to-end tests (minutes under ASan) run in the release configuration only: CI's
// budget is the sum of both configurations on two cores. Each one names which lighter test runs
// the same code under the sanitizers.
#include <gtest/gtest.h>

namespace ips::test {
#if defined(IPS_SANITIZED)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
}  // namespace ips::test

#define IPS_RELEASE_ONLY(under_sanitizers_see) \
  if (::ips::test::kSanitized) GTEST_SKIP() << "release-only; under the sanitizers see " << under_sanitizers_see
