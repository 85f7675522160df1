// csm_measure::computeBiasTruth's footprint reach (BiasTruthDesc::footprintRadii): a filter that
// averages over the pixel's footprint (the prefiltered filters at their mip) reads a shadow that
// lies within that footprint of a lit pixel, so such a pixel is "near an edge", not a place where
// darkening is acne. No GPU: the pixels are written by hand, the truth is Embree's.
#include <csm_measure/bias_metrics.hpp>
#include <csm_measure/raytracer.hpp>
#include <csm_measure/scene.hpp>

#include <gtest/gtest.h>

#include <vector>

namespace {

using csm_measure::BiasClass;
using csm_measure::PixelSample;

class BiasTruthFootprint : public ::testing::TestWithParam<double> {};

// Flat ground and a 1 m box standing at the origin under a sun straight overhead: its shadow is
// the square |x|, |z| <= 0.5. Texels of 10 cm, so the kernels' edge reach (6 texels) is 0.6 m.
TEST_P(BiasTruthFootprint, ALitPixelWithinItsFootprintOfAShadowIsNearAnEdge) {
  const glm::dvec3 o(GetParam(), 0.0, -GetParam());  // 0 and 10^7 m from the origin
  csm_measure::Scene scene(o);
  const uint32_t ground = scene.addMesh(csm_measure::makeGroundMesh(false, 100.0, 1, 0.0, 0.0));
  const uint32_t cube = scene.addMesh(csm_measure::makeCubeMesh());  // [-0.5, 0.5]^3
  scene.addInstance({ground, o});
  csm_measure::Instance box;
  box.mesh = cube;
  box.translationWs = o + glm::dvec3(0.0, 0.5, 0.0);
  box.kind = csm_measure::InstanceKind::kBuilding;
  box.closed = true;
  scene.addInstance(box);
  const csm_measure::RayTracer tracer(scene);
  const csm::DirectionalLight sun{glm::dvec3(0.0, -1.0, 0.0)};
  csm::CascadeFrame frame;
  frame.cascadeCount = 1;
  frame.cascades[0].texelSizeLs = glm::dvec2(0.1);
  frame.cameraPositionWs = o + glm::dvec3(0.0, 10.0, 20.0);
  frame.cameraForwardWs = glm::normalize(glm::dvec3(0.0, -0.5, -1.0));
  auto pixel = [&](uint32_t x, double xm, float footprintM) {
    PixelSample p;
    p.x = x;
    p.posWs = o + glm::dvec3(xm, 0.0, 0.0);
    p.normalWs = glm::vec3(0.0f, 1.0f, 0.0f);
    p.shadow = 1.0f;
    p.cascade = 0;
    p.footprintM = footprintM;
    return p;
  };
  // 1.5 m from the shadow's edge with a 0.5 m footprint (reach 0.6 + 4 x 0.5 = 2.6 m); 4.5 m
  // from it with the same footprint; 1.5 m from it with a 0.1 m footprint (reach 1.0 m).
  const std::vector<PixelSample> px = {pixel(0, 2.0, 0.5f), pixel(1, 5.0, 0.5f),
                                       pixel(2, 2.0, 0.1f)};
  csm_measure::BiasTruthDesc kernels;  // footprintRadii 0: the percentage-closer kernels
  const csm_measure::BiasTruth a =
      csm_measure::computeBiasTruth(px, 3, 1, frame, tracer, sun, kernels);
  EXPECT_EQ(a.at(0, 0), BiasClass::kLitInterior);
  EXPECT_EQ(a.at(1, 0), BiasClass::kLitInterior);
  EXPECT_EQ(a.at(2, 0), BiasClass::kLitInterior);
  csm_measure::BiasTruthDesc mips;
  mips.footprintRadii = 4.0;
  const csm_measure::BiasTruth b =
      csm_measure::computeBiasTruth(px, 3, 1, frame, tracer, sun, mips);
  EXPECT_EQ(b.at(0, 0), BiasClass::kLitNearEdge);
  EXPECT_EQ(b.at(1, 0), BiasClass::kLitInterior);
  EXPECT_EQ(b.at(2, 0), BiasClass::kLitInterior);
}

INSTANTIATE_TEST_SUITE_P(Origins, BiasTruthFootprint, ::testing::Values(0.0, 1e7));

}  // namespace
