// Across a blend band the shadow factor changes smoothly: csm.glsl evaluated in a compute shader
// (glue::ShadowProbe, shadow_probe.comp) at exact points on the plane along a line that runs
// through the band, beside the shadow edge of a rail that lies along the view direction.
#include <gtest/gtest.h>

#include <engine/debug.hpp>
#include <engine/errors.hpp>
#include <engine/memory.hpp>
#include <engine/pipeline.hpp>
#include <glue/shadow_probe.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <span>

#include "shadow_scene.hpp"

namespace csm_test {
namespace {

/// glue::ShadowProbe over the scene: records the scene's shadow pass, then evaluates csm.glsl at
/// the given world points (normal +Y) with one kernel and blend mode.
class Probe {
 public:
  Probe(engine::Context& ctx, VkDescriptorSetLayout shadowLayout, csm::PcfKernel kernel, bool blend)
      : ctx_(ctx), probe_(ctx, shadowLayout), kernel_(kernel), blend_(blend) {}

  /// Renders the shadow pass of `frame` and evaluates csm.glsl at `pointsWs`.
  std::vector<glue::ProbeResult> run(ShadowScene& scene, const csm::CascadeFrame& frame,
                                     const std::vector<glm::dvec3>& pointsWs) {
    std::vector<glue::ProbePoint> points;
    for (const glm::dvec3& p : pointsWs) {
      points.push_back({glm::vec3(p - frame.cameraPositionWs), glm::vec3(0.0f, 1.0f, 0.0f)});
    }
    probe_.setPoints(points);
    ctx_.submitAndWait([&](VkCommandBuffer cmd) {
      const csm::CascadeFrame recorded = scene.recordShadow(cmd, csm::DebugMode::kNone);
      // The view recomputes the frame for the same camera: the probe's frame is the recorded one.
      EXPECT_EQ(recorded.splitsM, frame.splitsM);
      EXPECT_EQ(recorded.cascades[0].boxCenterWs, frame.cascades[0].boxCenterWs);
      probe_.record(cmd, scene.renderer().lightingSet(), kernel_, blend_);
    });
    return probe_.results();
  }
  /// The shadow factors of run().
  std::vector<float> shadows(ShadowScene& scene, const csm::CascadeFrame& frame,
                             const std::vector<glm::dvec3>& pointsWs) {
    std::vector<float> out;
    for (const glue::ProbeResult& r : run(scene, frame, pointsWs)) out.push_back(r.shadow);
    return out;
  }

 private:
  engine::Context& ctx_;
  glue::ShadowProbe probe_;
  csm::PcfKernel kernel_;
  bool blend_;
};

double maxJump(const std::vector<float>& s, size_t begin, size_t end) {
  double m = 0.0;
  for (size_t i = begin + 1; i < end; ++i) m = std::max(m, double(std::abs(s[i] - s[i - 1])));
  return m;
}

TEST(ShadowBlendBand, NoJumpAcrossTheBandLargerThanTheKernelStep) {
  {
    ShadowScene scene;
    csm::ShadowSettings settings;
    settings.cascadeCount = 2;
    settings.resolution = 1024;
    settings.shadowDistanceM = 60.0;
    settings.blendBand = 0.3;
    CSM_ASSERT_OK(scene.update(settings));
    const csm::CascadeFrame frame = scene.computeFrame();
    ASSERT_FALSE(frame.cascades[0].empty);
    ASSERT_FALSE(frame.cascades[1].empty);
    const double split = frame.splitsM[1];
    const double bandStart = split - settings.blendBand * (split - frame.splitsM[0]);
    const double texel1 = frame.cascades[1].texelSizeM();

    // The rail's shadow edge on the plane (the +x side: the light travels toward +x).
    const csm::AabbWs rail = scene.shapes.boxes.back();
    const glm::dvec3 l = glm::normalize(scene.light.directionWs);
    const double edgeX = rail.maxWs.x + rail.maxWs.y * (l.x / -l.y);

    // Points on the plane with a given view depth and x: the camera looks along -z and down.
    const glm::dvec3 cam = scene.camera.positionWs;
    const glm::dvec3 fwd = scene.camera.forwardWs();
    auto atDepth = [&](double x, double depth) {
      // depth = dot((x, 0, z) - cam, fwd) -> z
      const double z = cam.z + (depth - (x - cam.x) * fwd.x - (0.0 - cam.y) * fwd.y) / fwd.z;
      return glm::dvec3(x, 0.0, z);
    };
    const int n = 800;
    const double from = bandStart - 1.0, to = split + 1.0;
    const double spacing = (to - from) / (n - 1);

    for (csm::PcfKernel kernel :
         {csm::PcfKernel::k1Tap, csm::PcfKernel::kTent3, csm::PcfKernel::kTent5,
          csm::PcfKernel::kTent7, csm::PcfKernel::kPoisson16, csm::PcfKernel::kPcss}) {
      SCOPED_TRACE(csm::kernelName(kernel));
      const double offset = 0.35 * texel1 * csm::kernelRadiusTexels(kernel);
      std::vector<glm::dvec3> points;
      // Along the view direction, inside the shadow near its edge, through the band.
      for (int i = 0; i < n; ++i) points.push_back(atDepth(edgeX - offset, from + spacing * i));
      // Across the edge at the same spacing, once in each cascade: the kernel's own steps.
      for (double depth : {bandStart - 0.5, split + 0.5}) {
        for (int i = 0; i < n; ++i) {
          points.push_back(atDepth(edgeX - 0.5 * n * spacing + spacing * i, depth));
        }
      }
      std::vector<float> s, hard;
      {
        Probe probe(scene.context(), scene.renderer().lightingSetLayout(), kernel, true);
        s = probe.shadows(scene, frame, points);
      }
      {
        Probe probe(scene.context(), scene.renderer().lightingSetLayout(), kernel, false);
        hard = probe.shadows(scene, frame, points);
      }
      const double kernelStep = std::max(maxJump(s, n, 2 * n), maxJump(s, 2 * n, 3 * n));
      // The band: samples with view depth in [bandStart, split].
      const size_t b0 = size_t(std::ceil((bandStart - from) / spacing));
      const size_t b1 = std::min(size_t(std::floor((split - from) / spacing)) + 2, size_t(n));
      const double bandJump = maxJump(s, b0, b1);
      const double hardJump = maxJump(hard, b0, b1);
      std::printf(
          "%-10s kernel step %.4f, largest jump in the band: blended %.4f, hard %.4f"
          " (s %.3f -> %.3f)\n",
          csm::kernelName(kernel), kernelStep, bandJump, hardJump, s[b0], s[b1 - 1]);
      EXPECT_GT(kernelStep, 0.0) << "the probe line must cross the shadow edge";
      EXPECT_LE(bandJump, kernelStep + 1e-3);
      // The test can fail: without the blend the switch is a larger jump.
      EXPECT_GT(hardJump, bandJump);
    }
  }
  EXPECT_EQ(validationMessages(), 0u);
}

// The GPU's cascade selection (csmSelectCascade in csm.glsl) against the CPU mirror
// (csm::selectCascade) at many points through every cascade and band: the same cascade, the same
// blended cascade and the same blend weight, except within float rounding of a boundary.
TEST(ShadowSelection, GpuIndexAndBlendWeightMatchTheCpuMirror) {
  {
    ShadowScene scene;
    csm::ShadowSettings settings;
    settings.cascadeCount = 4;
    settings.resolution = 512;
    settings.shadowDistanceM = 60.0;
    settings.blendBand = 0.25;
    CSM_ASSERT_OK(scene.update(settings));
    const csm::CascadeFrame frame = scene.computeFrame();
    const glm::dvec3 cam = scene.camera.positionWs;
    const glm::dvec3 fwd = scene.camera.forwardWs();
    const glm::dvec3 right = glm::normalize(glm::cross(fwd, glm::dvec3(0, 1, 0)));
    const glm::dvec3 up = glm::cross(right, fwd);
    // Depths from before the first split to past the last, with lateral offsets.
    const int n = 24000;
    std::vector<glm::dvec3> points;
    for (int i = 0; i < n; ++i) {
      const double depth = 1.1 * frame.shadowFarM * (i + 0.5) / n;
      const double x = 0.4 * depth * std::sin(0.37 * i), y = 0.2 * depth * std::cos(0.91 * i);
      points.push_back(cam + depth * fwd + x * right + y * up);
    }
    std::vector<glue::ProbeResult> gpu;
    {
      Probe probe(scene.context(), scene.renderer().lightingSetLayout(), csm::PcfKernel::k1Tap,
                  true);
      gpu = probe.run(scene, frame, points);
    }
    std::vector<double> edges;  // splits and band starts (view depth, m)
    for (uint32_t c = 0; c < frame.cascadeCount; ++c) {
      const double nearM = frame.splitsM[c], farM = frame.splitsM[c + 1];
      edges.push_back(nearM);
      edges.push_back(farM);
      edges.push_back(farM - settings.blendBand * (farM - nearM));
    }
    uint64_t compared = 0, skipped = 0, indexDiffer = 0, blendDiffer = 0, inBand = 0;
    double maxWeightDiff = 0.0;
    for (int i = 0; i < n; ++i) {
      const double depth = csm::viewDepthM(frame, points[i]);
      bool nearEdge = false;
      for (double e : edges) nearEdge = nearEdge || std::abs(depth - e) < 1e-4 * std::max(1.0, e);
      if (nearEdge) {
        ++skipped;
        continue;
      }
      const csm::CascadeSelection cpu = csm::selectCascade(frame, depth, settings.blendBand);
      const int gIndex = gpu[size_t(i)].cascade;
      const int gBlend = gpu[size_t(i)].blendCascade;
      const double gWeight = gpu[size_t(i)].blendWeight;
      ++compared;
      indexDiffer += gIndex != cpu.index ? 1 : 0;
      blendDiffer += gBlend != cpu.blendIndex ? 1 : 0;
      if (cpu.blendIndex >= 0) {
        ++inBand;
        maxWeightDiff = std::max(maxWeightDiff, std::abs(gWeight - double(cpu.blendWeight)));
      } else {
        maxWeightDiff = std::max(maxWeightDiff, std::abs(gWeight));
      }
    }
    std::printf(
        "selection: %llu points compared (%llu in bands, %llu within rounding of an edge "
        "left out): index differs at %llu, blend cascade at %llu, largest weight "
        "difference %.2e\n",
        (unsigned long long)compared, (unsigned long long)inBand, (unsigned long long)skipped,
        (unsigned long long)indexDiffer, (unsigned long long)blendDiffer, maxWeightDiff);
    EXPECT_GT(compared, uint64_t(0.99 * n));
    EXPECT_GT(inBand, uint64_t(0.05 * n));  // the bands of the first three cascades
    EXPECT_EQ(indexDiffer, 0u);
    EXPECT_EQ(blendDiffer, 0u);
    EXPECT_LT(maxWeightDiff, 1e-3);
  }
  EXPECT_EQ(validationMessages(), 0u);
}

// The probe's depth-gap diagnostic (ProbeResult::depthGapM: how near a receiver sits to a depth
// tie, printed beside every shimmer report's visible changes) reads the receiver's own texels in
// windowed layers too. Stabilised per-layer cascades address each layer toroidally, so after the
// camera moved the box no longer starts at layer texel 0; read without the wrap, the gap of lit
// ground came from texels metres away along the light (it reported 0.3 to 20 m where the real
// gap was under 2 cm, and sent a diagnosis of the sweep's shimmer the wrong way).
TEST(ShadowProbe, DepthGapReadsTheReceiversTexelsThroughTheWrap) {
  {
    ShadowScene scene;
    CSM_ASSERT_OK(scene.update(testSettings(4, 512)));
    Probe probe(scene.context(), scene.renderer().lightingSetLayout(), csm::PcfKernel::kTent3,
                true);
    // First frame: the windows anchor at the boxes. Then 9 m along the light's horizontal
    // direction, so the boxes move hundreds of texels inside their windows (and a read that
    // misses the wrap lands on ground metres nearer or farther along the light).
    (void)probe.run(scene, scene.computeFrame(), {scene.camera.positionWs});
    const glm::dvec3 along =
        glm::normalize(glm::dvec3(scene.light.directionWs.x, 0.0, scene.light.directionWs.z));
    scene.camera.positionWs += 9.0 * along;
    const csm::CascadeFrame frame = scene.computeFrame();
    // Lit ground far from every shadow edge, inside the cascades.
    std::vector<glm::dvec3> points;
    scene.forEachGroundPixel(320, 180, [&](uint32_t x, uint32_t y, const glm::dvec3& p) {
      if (x % 4 != 0 || y % 4 != 0) return;
      const csm::CascadeSelection sel = scene.selection(frame, p);
      if (sel.index < 0 || scene.shadowedAnalytic(p)) return;
      const double texel = frame.cascades[uint32_t(sel.index)].texelSizeLs.x;
      if (scene.farFromEdge(p, 4.0 * texel, frame)) points.push_back(p);
    });
    ASSERT_GT(points.size(), 300u);
    const std::vector<glue::ProbeResult> r = probe.run(scene, frame, points);
    double worst = 0.0;
    for (size_t i = 0; i < points.size(); ++i) {
      ASSERT_GE(r[i].cascade, 0);
      // Lit flat ground: the nearest stored depth of its 5x5 texels is its own plane, within
      // the bias and the plane's change over a texel (the 4th cascade's texel is under 0.3 m).
      worst = std::max(worst, double(r[i].depthGapM));
      EXPECT_LT(r[i].depthGapM, 0.25f) << "point " << i << " in cascade " << r[i].cascade;
      if (HasFailure()) break;
    }
    std::printf("depth gap of %zu lit ground points after a 9 m move: at most %.4f m\n",
                points.size(), worst);
  }
  EXPECT_EQ(validationMessages(), 0u);
}

// Toward the shadow distance shadows fade to lit (ShadowSettings::fadeFraction) instead of ending
// at a line: csm.glsl at points on the ground in a slab's shadow, along the view through the
// fade, against the CPU mirror (csm::shadowFade). With fadeFraction 0 the shadow holds to the
// end and stops there, which is what the fade replaces.
TEST(ShadowFade, RampsToLitOverTheFadeAndCutsHardWithoutIt) {
  for (double fraction : {0.1, 0.0}) {
    SCOPED_TRACE(fraction);
    ShadowScene scene;
    // A slab 3 m above the ground whose shadow covers the ground along the view past 60 m.
    scene.shapes.boxes.push_back({{-20.0, 3.0, -90.0}, {20.0, 3.5, -10.0}});
    csm::ShadowSettings settings;
    settings.cascadeCount = 2;
    settings.resolution = 1024;
    settings.shadowDistanceM = 50.0;
    settings.fadeFraction = fraction;
    CSM_ASSERT_OK(scene.update(settings));
    const csm::CascadeFrame frame = scene.computeFrame();
    ASSERT_EQ(frame.shadowFarM, 50.0);
    ASSERT_EQ(frame.fadeLengthM, 50.0 * fraction);
    const glm::dvec3 cam = scene.camera.positionWs;
    const glm::dvec3 fwd = scene.camera.forwardWs();
    std::vector<glm::dvec3> points;
    std::vector<double> depths;
    for (double depth = 30.0; depth <= 55.0; depth += 0.05) {
      const double z = cam.z + (depth - (0.0 - cam.y) * fwd.y) / fwd.z;  // on the ground, x = 0
      points.push_back({0.0, 0.0, z});
      depths.push_back(csm::viewDepthM(frame, points.back()));
      ASSERT_TRUE(scene.shapes.occluded(points.back(), -glm::normalize(scene.light.directionWs)));
    }
    std::vector<glue::ProbeResult> gpu;
    {
      Probe probe(scene.context(), scene.renderer().lightingSetLayout(), csm::PcfKernel::kTent3,
                  true);
      gpu = probe.run(scene, frame, points);
    }
    uint64_t faded = 0;
    double worst = 0.0;
    for (size_t i = 0; i < points.size(); ++i) {
      const double d = depths[i];
      const double s = gpu[i].shadow;
      if (d >= frame.shadowFarM * (1.0 + 1e-6)) {
        EXPECT_EQ(s, 1.0) << "beyond the shadows at " << d;
        continue;
      }
      if (d >= frame.shadowFarM * (1.0 - 1e-6)) continue;  // on the end, within float rounding
      // In shadow (0) faded by the CPU mirror's weight; float rounding of the view depth moves
      // the weight by at most its slope x 1e-5 m.
      const double expected = csm::shadowFade(frame, d);
      faded += expected > 0.0 ? 1 : 0;
      worst = std::max(worst, std::abs(s - expected));
    }
    std::printf("fade %.2f: %llu points fading, largest difference from the mirror %.2e\n",
                fraction, static_cast<unsigned long long>(faded), worst);
    EXPECT_LE(worst, 2e-3);
    if (fraction > 0.0) {
      EXPECT_GT(faded, 50u);  // the probe line runs through the fade
    } else {
      EXPECT_EQ(faded, 0u);  // the hard cut: fully shadowed up to the end
    }
  }
  EXPECT_EQ(validationMessages(), 0u);
}

}  // namespace
}  // namespace csm_test
