// Explicit split positions (ShadowSettings::splitPositions) instead of the practical lambda.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "test_util.hpp"

namespace csm {
namespace {

TEST(ExplicitSplits, PlaceTheSplitsAtTheGivenFractionsOfTheRange) {
  ShadowSettings s;
  s.cascadeCount = 4;
  s.shadowDistanceM = 400.0;
  s.splitPositions = {0.05, 0.2, 0.5};
  ASSERT_TRUE(s.explicitSplits());
  Camera cam;
  cam.nearM = 0.5;
  cam.farM = 400.0;
  // With the size ladder on (the default) the interior splits land on the ladder's nearest rung,
  // as lambda's do: within one rung (2^(1/8)) of the position asked for.
  {
    const CascadeFrame laddered = test::computeOrDie(s, cam, DirectionalLight{});
    const double n = laddered.splitsM[0], far = laddered.splitsM[4];
    for (int i = 1; i < 4; ++i) {
      const double asked = n + s.splitPositions[i - 1] * (far - n);
      EXPECT_LE(std::abs(std::log2(laddered.splitsM[i] / asked)), 1.0 / 8.0 + 1e-12) << i;
    }
  }
  // The ladder off: exactly where they are asked for.
  s.diagnostics.sizeLadder = false;
  const CascadeFrame f = test::computeOrDie(s, cam, DirectionalLight{});
  const double n = f.splitsM[0], far = f.splitsM[4];
  EXPECT_EQ(n, cam.nearM);
  EXPECT_EQ(far, f.shadowFarM);
  for (int i = 1; i < 4; ++i) {
    EXPECT_NEAR(f.splitsM[i], n + s.splitPositions[i - 1] * (far - n), 1e-9 * far) << i;
    EXPECT_EQ(f.cascades[i].splitNearM, f.splitsM[i]);
  }
  // The lambda is ignored while positions are given; all zero gives the lambda back.
  ShadowSettings lambda = s;
  lambda.splitLambda = 0.0;
  EXPECT_EQ(test::computeOrDie(lambda, cam, DirectionalLight{}).splitsM, f.splitsM);
  lambda.splitPositions = {};
  EXPECT_FALSE(lambda.explicitSplits());
  EXPECT_EQ(test::computeOrDie(lambda, cam, DirectionalLight{}).splitsM, uniformSplits(n, far, 4));
}

TEST(ExplicitSplits, InvalidPositionsAreRefusedNamingTheEntry) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  struct Case {
    std::array<double, kMaxCascades - 1> positions;
    const char* field;
  };
  const Case cases[] = {{{0.5, 0.4, 0.9}, "settings.splitPositions[1]"},
                        {{0.2, 0.5, 1.0}, "settings.splitPositions[2]"},
                        {{-0.1, 0.5, 0.9}, "settings.splitPositions[0]"},
                        {{0.0, 0.5, 0.9}, "settings.splitPositions[0]"},
                        {{0.2, nan, 0.9}, "settings.splitPositions[1]"},
                        {{0.2, 0.2, 0.9}, "settings.splitPositions[1]"}};
  for (const Case& c : cases) {
    ShadowSettings s;
    s.cascadeCount = 4;
    s.splitPositions = c.positions;
    const auto e = validate(s);
    ASSERT_TRUE(e.has_value()) << c.field;
    EXPECT_EQ(e->field, c.field) << e->message();
    EXPECT_NE(e->message().find("(0, 1)"), std::string::npos) << e->message();
  }
  // Entries past cascadeCount - 1 do not matter.
  ShadowSettings two;
  two.cascadeCount = 2;
  two.splitPositions = {0.3, -5.0, 7.0};
  EXPECT_FALSE(validate(two).has_value());
}

}  // namespace
}  // namespace csm
