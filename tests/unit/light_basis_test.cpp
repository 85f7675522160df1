#include <gtest/gtest.h>

#include "test_util.hpp"

namespace csm {
namespace {

void expectOrthonormalRightHanded(const glm::dmat3& b, const glm::dvec3& dir) {
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 3; ++k) {
      ASSERT_TRUE(std::isfinite(b[i][k]));
      EXPECT_NEAR(glm::dot(b[i], b[k]), i == k ? 1.0 : 0.0, 1e-12);
    }
  }
  EXPECT_NEAR(glm::dot(glm::cross(b[0], b[1]), b[2]), 1.0, 1e-12);
  EXPECT_NEAR(glm::length(b[2] - glm::normalize(dir)), 0.0, 1e-15);
}

TEST(LightBasis, SpecialDirections) {
  const glm::dvec3 dirs[] = {{0, -1, 0},     {0, 1, 0},  {1, 0, 0},       {0, 0, -1},
                             {0, 0, 1},      {-1, 0, 0}, {1e-300, -1, 0}, {0, -1, 1e-17},
                             {0, 1e-20, -1}, {3, -4, 12}};
  for (const auto& d : dirs) expectOrthonormalRightHanded(lightBasisWs(d), d);
}

TEST(LightBasis, RandomDirections) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n;
  for (int i = 0; i < 100000; ++i) {
    const glm::dvec3 d(n(rng), n(rng), n(rng));
    expectOrthonormalRightHanded(lightBasisWs(d), d);
  }
}

TEST(LightBasis, SmoothOverEveryDownwardLight) {
  // Sweep the sun across the sky, straight down included: neighbouring directions get
  // neighbouring bases (no jump such as a lookAt fallback produces).
  for (double az = 0.0; az < 360.0; az += 7.5) {
    glm::dmat3 prev{};
    bool first = true;
    for (double el = 1.0; el <= 90.0; el += 0.25) {
      const double a = glm::radians(az), e = glm::radians(el);
      const glm::dvec3 dir(std::cos(e) * std::cos(a), -std::sin(e), std::cos(e) * std::sin(a));
      const glm::dmat3 b = lightBasisWs(dir);
      if (!first) {
        for (int k = 0; k < 2; ++k) EXPECT_LT(glm::length(b[k] - prev[k]), 0.02) << az << " " << el;
      }
      prev = b;
      first = false;
    }
  }
}

}  // namespace
}  // namespace csm
