// Receiver-marked tiles on the CPU (csm/receiver_tiles.hpp): the reach of each filter, the grid
// that covers a cascade's box 10^7 m from the origin, the cascades a receiver is shaded with
// (the blend band) and the tiles a receiver and a rectangle mark, edges included.
#include <gtest/gtest.h>

#include <cmath>

#include <csm/cascades.hpp>
#include <csm/gpu_layout.hpp>
#include <csm/moments.hpp>
#include <csm/receiver_tiles.hpp>

namespace {

csm::CascadeFrame frameAt(const csm::ShadowSettings& s, const glm::dvec3& at) {
  csm::Camera cam;
  cam.positionWs = at;
  cam.orientationWs = glm::angleAxis(glm::radians(-10.0), glm::dvec3(1, 0, 0));
  cam.nearM = 0.5;
  cam.farM = 2000.0;
  const csm::DirectionalLight light{glm::dvec3(0.3, -0.8, 0.52)};
  auto f = csm::computeCascades(s, cam, light);
  EXPECT_TRUE(f.ok());
  return f.value();
}

TEST(ReceiverTiles, ReachOfEachFilterInTexels) {
  csm::ShadowSettings s;
  const csm::CascadeFrame f = frameAt(s, glm::dvec3(0.0, 30.0, 0.0));
  const double offset = double(s.normalOffsetTexels) * std::sqrt(2.0);
  for (std::uint32_t i = 0; i < f.cascadeCount; ++i) {
    s.kernel = csm::PcfKernel::kTent3;
    EXPECT_DOUBLE_EQ(csm::receiverSampleReachTexels(s, f, i), 2.0 + offset);
    s.kernel = csm::PcfKernel::k1Tap;
    EXPECT_DOUBLE_EQ(csm::receiverSampleReachTexels(s, f, i), 1.0 + offset);
    // The world-space kernel spreads the taps by texel_0 / texel_i.
    s.kernel = csm::PcfKernel::kTent7;
    s.worldSpaceKernel = true;
    const double scale = f.cascades[0].texelSizeM() / f.cascades[i].texelSizeM();
    EXPECT_DOUBLE_EQ(csm::receiverSampleReachTexels(s, f, i), 1.0 + 3.0 * scale + offset);
    s.worldSpaceKernel = false;
    // PCSS: the blocker search (the widest penumbra radius, at least a texel) and its tap.
    s.kernel = csm::PcfKernel::kPcss;
    const double texel = f.cascades[i].texelSizeM();
    EXPECT_DOUBLE_EQ(csm::receiverSampleReachTexels(s, f, i),
                     std::max(0.5 * s.maxPenumbraM / texel, 1.0) + 1.25);
    s.kernel = csm::PcfKernel::kMsm;
    EXPECT_DOUBLE_EQ(csm::receiverSampleReachTexels(s, f, i),
                     1.0 + double(csm::momentBlurRadiusTexels(s.momentBlurM, texel)) + offset);
  }
  EXPECT_EQ(csm::receiverSampleReachTexels(s, f, f.cascadeCount), 0.0);
}

TEST(ReceiverTiles, GridCoversTheBoxFarFromTheOrigin) {
  csm::ShadowSettings s;
  s.resolution = 1024;
  for (const glm::dvec3 at : {glm::dvec3(0.0, 30.0, 0.0), glm::dvec3(-1e7, 30.0, 1e7)}) {
    const csm::CascadeFrame f = frameAt(s, at);
    const csm::ReceiverTileMarks m = csm::emptyReceiverTileMarks(s, f);
    ASSERT_TRUE(m.present());
    EXPECT_EQ(m.tileTexels, 1024u / csm::kTilesPerSide);
    const glm::dmat3 basisT = glm::transpose(f.lightBasisWs);
    for (std::uint32_t i = 0; i < f.cascadeCount; ++i) {
      const csm::Cascade& c = f.cascades[i];
      const double texel = c.texelSizeM();
      ASSERT_EQ(m.texelM[i], texel);
      const glm::dvec3 center = basisT * c.boxCenterWs;
      // The box's first and last world texels lie in the grid.
      for (int a = 0; a < 2; ++a) {
        const double lo = (center[a] - c.halfExtentLs[a]) / texel;
        const double hi = (center[a] + c.halfExtentLs[a]) / texel;
        const double gridLo = double(m.gridOrigin[i][a]) * m.tileTexels;
        const double gridHi = gridLo + double(csm::kTileGridSide * m.tileTexels);
        EXPECT_LE(gridLo, lo + 0.5) << "cascade " << i << " axis " << a;
        EXPECT_GE(gridHi, hi - 0.5) << "cascade " << i << " axis " << a;
        EXPECT_LT(lo - gridLo, double(m.tileTexels) + 0.5) << "cascade " << i << " axis " << a;
      }
      // A receiver at the box centre marks the tile that holds it, and only that one when it
      // is farther than the reach from the tile's sides.
      csm::ReceiverTileMarks one = m;
      const double tileM = texel * m.tileTexels;
      const glm::dvec2 tile = glm::floor(glm::dvec2(center) / tileM);
      const glm::dvec2 mid = (tile + 0.5) * tileM;
      csm::markTileRect(one, i, mid, mid);
      EXPECT_EQ(one.markedCount(i), 1u);
      const glm::dvec2 g = tile - glm::dvec2(m.gridOrigin[i]);
      EXPECT_TRUE(one.marked(i, std::uint32_t(g.x), std::uint32_t(g.y)));
      // Within the reach of a corner: the four tiles about it.
      csm::ReceiverTileMarks corner = m;
      const glm::dvec2 nearCorner = (tile + 1.0) * tileM - 0.5 * m.reachM[i];
      csm::markTileRect(corner, i, nearCorner, nearCorner);
      EXPECT_EQ(corner.markedCount(i), 4u);
      // A rectangle wider than the grid marks all of it; one beside it, nothing.
      csm::ReceiverTileMarks all = m;
      csm::markTileRect(all, i, glm::dvec2(center) - 1e4 * tileM, glm::dvec2(center) + 1e4 * tileM);
      EXPECT_EQ(all.markedCount(i), csm::kTileGridSide * csm::kTileGridSide);
      csm::ReceiverTileMarks none = m;
      const glm::dvec2 far = glm::dvec2(center) + 40.0 * tileM;
      csm::markTileRect(none, i, far, far);
      EXPECT_EQ(none.markedCount(i), 0u);
    }
  }
}

TEST(ReceiverTiles, TheBlendBandMarksTheNextCascade) {
  csm::ShadowSettings s;
  s.blendBand = 0.2;
  const csm::CascadeFrame f = frameAt(s, glm::dvec3(0.0, 30.0, 0.0));
  csm::ReceiverTileMarks m = csm::emptyReceiverTileMarks(s, f);
  for (std::uint32_t i = 0; i < f.cascadeCount; ++i) {
    const double nearM = f.splitsM[i], farM = f.splitsM[i + 1];
    EXPECT_DOUBLE_EQ(m.blendStartM[i], farM - 0.2 * (farM - nearM));
    const double inside = 0.5 * (nearM + m.blendStartM[i]);
    EXPECT_EQ(csm::shadingCascades(m, inside), std::make_pair(int(i), -1));
    const double band = 0.5 * (m.blendStartM[i] + farM);
    const int next = i + 1 < f.cascadeCount ? int(i + 1) : -1;
    EXPECT_EQ(csm::shadingCascades(m, band), std::make_pair(int(i), next));
  }
  EXPECT_EQ(csm::shadingCascades(m, f.splitsM[f.cascadeCount] + 1.0), std::make_pair(-1, -1));
  // A receiver in cascade 0's band marks a tile in 0 and in 1; one before the band only in 0.
  const glm::dvec3 fwd = f.cameraForwardWs;
  const double d = 0.5 * (m.blendStartM[0] + f.splitsM[1]);
  EXPECT_EQ(csm::markReceiverTiles(m, f.cameraPositionWs + fwd * d, d), 0);
  EXPECT_GE(m.markedCount(0), 1u);
  EXPECT_GE(m.markedCount(1), 1u);
  csm::ReceiverTileMarks before = csm::emptyReceiverTileMarks(s, f);
  const double d0 = 0.5 * (f.splitsM[0] + m.blendStartM[0]);
  EXPECT_EQ(csm::markReceiverTiles(before, f.cameraPositionWs + fwd * d0, d0), 0);
  EXPECT_GE(before.markedCount(0), 1u);
  EXPECT_EQ(before.markedCount(1), 0u);
}

}  // namespace
