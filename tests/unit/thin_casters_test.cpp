// The thin casters' widening rule (csm/thin_casters.hpp): a caster at least half a texel wide is
// widened to exactly one texel, thinner or unknown ones by what the host asked, never less.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "csm/thin_casters.hpp"

namespace {

using csm::thinCasterMaxWidenTexels;
using csm::thinCasterWidenTexels;

TEST(ThinCasters, AtLeastHalfATexelWideIsWidenedToExactlyOneTexel) {
  // The sample world's poles (0.28 m) under its third cascade's 0.459 m texels.
  const float w = thinCasterWidenTexels(0.0625f, 0.28f, 0.459);
  EXPECT_NEAR(0.28 + 2.0 * w * 0.459, 0.459, 1e-6);
  // Over the whole band [t / 2, t): the widened caster is one texel wide, at most twice its width.
  for (double ratio = 0.5; ratio < 1.0; ratio += 1.0 / 64.0) {
    const double texel = 0.37;
    const float width = float(ratio * texel);
    const float widen = thinCasterWidenTexels(1e-4f, width, texel);
    const double drawn = double(width) + 2.0 * widen * texel;
    EXPECT_NEAR(drawn, texel, 1e-6) << ratio;
    EXPECT_LE(drawn, 2.0 * width + 1e-6) << ratio;
    EXPECT_LE(widen, csm::kThinWidthRuleMaxTexels) << ratio;
  }
}

TEST(ThinCasters, ThinnerUnknownOrWiderCastersGetWhatWasAsked) {
  // A 3 cm cable under 0.459 m texels: widening it to a texel would make it 15 times as wide.
  EXPECT_EQ(thinCasterWidenTexels(0.0625f, 0.03f, 0.459), 0.0625f);
  // Just under half a texel: what was asked.
  EXPECT_EQ(thinCasterWidenTexels(0.0625f, 0.2f, 0.41), 0.0625f);
  // Unknown width (0), a texel or wider.
  EXPECT_EQ(thinCasterWidenTexels(0.0625f, 0.0f, 0.459), 0.0625f);
  EXPECT_EQ(thinCasterWidenTexels(0.0625f, 0.459f, 0.459), 0.0625f);
  EXPECT_EQ(thinCasterWidenTexels(0.0625f, 3.0f, 0.459), 0.0625f);
  // Never less than asked: a host asking for half a texel keeps it on a 0.7-texel caster.
  EXPECT_EQ(thinCasterWidenTexels(0.5f, 0.7f, 1.0), 0.5f);
  EXPECT_FLOAT_EQ(thinCasterWidenTexels(0.1f, 0.7f, 1.0), 0.15f);
  // Off stays off, whatever the width.
  EXPECT_EQ(thinCasterWidenTexels(0.0f, 0.3f, 0.459), 0.0f);
}

TEST(ThinCasters, BadInputNeverGivesNaNOrMoreThanTheMargin) {
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (float asked : {0.0f, 0.0625f, 0.5f, 4.0f, -1.0f, nan, inf}) {
    for (float width : {0.0f, 0.03f, 0.3f, 1e3f, -0.3f, nan, inf}) {
      for (double texel : {1e-4, 0.459, 1e4, 0.0, -1.0, double(nan), double(inf)}) {
        const float w = thinCasterWidenTexels(asked, width, texel);
        EXPECT_TRUE(std::isfinite(w)) << asked << " " << width << " " << texel;
        EXPECT_GE(w, 0.0f);
        EXPECT_LE(w, thinCasterMaxWidenTexels(asked)) << asked << " " << width << " " << texel;
      }
    }
  }
  EXPECT_EQ(thinCasterMaxWidenTexels(0.0625f), csm::kThinWidthRuleMaxTexels);
  EXPECT_EQ(thinCasterMaxWidenTexels(1.0f), 1.0f);
  EXPECT_EQ(thinCasterMaxWidenTexels(0.0f), 0.0f);
}

}  // namespace
