// Every invalid input is refused with a message that names the field, its value and the range.
#include <gtest/gtest.h>

#include <functional>
#include <limits>

#include <csm/names.hpp>

#include "test_util.hpp"

namespace csm {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

struct Case {
  const char* name;
  const char* field;
  std::function<void(ShadowSettings&, Camera&, DirectionalLight&)> spoil;
};

class ValidationTest : public ::testing::TestWithParam<Case> {};

TEST_P(ValidationTest, RefusedWithFieldNameAndRange) {
  ShadowSettings s;
  Camera c;
  DirectionalLight l;
  ASSERT_FALSE(validate(s, c, l).has_value());
  GetParam().spoil(s, c, l);
  const auto error = validate(s, c, l);
  ASSERT_TRUE(error.has_value());
  EXPECT_EQ(error->field, GetParam().field);
  const std::string msg = error->message();
  EXPECT_NE(msg.find(GetParam().field), std::string::npos) << msg;
  EXPECT_NE(msg.find("allowed"), std::string::npos) << msg;
  // computeCascades refuses the same input with the same error and produces nothing.
  const auto result = computeCascades(s, c, l);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.error().field, GetParam().field);
}

const Case kCases[] = {
    {"count0", "settings.cascadeCount", [](auto& s, auto&, auto&) { s.cascadeCount = 0; }},
    {"count9", "settings.cascadeCount", [](auto& s, auto&, auto&) { s.cascadeCount = 9; }},
    {"res128", "settings.resolution", [](auto& s, auto&, auto&) { s.resolution = 128; }},
    {"res300", "settings.resolution", [](auto& s, auto&, auto&) { s.resolution = 300; }},
    {"res32k", "settings.resolution", [](auto& s, auto&, auto&) { s.resolution = 32768; }},
    {"lambdaNeg", "settings.splitLambda", [](auto& s, auto&, auto&) { s.splitLambda = -0.1; }},
    {"lambdaBig", "settings.splitLambda", [](auto& s, auto&, auto&) { s.splitLambda = 1.01; }},
    {"lambdaNaN", "settings.splitLambda", [](auto& s, auto&, auto&) { s.splitLambda = kNaN; }},
    {"distNaN", "settings.shadowDistanceM",
     [](auto& s, auto&, auto&) { s.shadowDistanceM = kNaN; }},
    {"distInf", "settings.shadowDistanceM",
     [](auto& s, auto&, auto&) { s.shadowDistanceM = kInf; }},
    {"distBelowNear", "settings.shadowDistanceM",
     [](auto& s, auto& c, auto&) { s.shadowDistanceM = c.nearM * 0.5; }},
    {"bandNeg", "settings.blendBand", [](auto& s, auto&, auto&) { s.blendBand = -0.01; }},
    {"bandBig", "settings.blendBand", [](auto& s, auto&, auto&) { s.blendBand = 0.51; }},
    {"fadeNeg", "settings.fadeFraction", [](auto& s, auto&, auto&) { s.fadeFraction = -0.01; }},
    {"cacheRestore4", "settings.diagnostics.cacheRestore",
     [](auto& s, auto&, auto&) { s.diagnostics.cacheRestore = static_cast<CacheRestore>(4); }},
    {"fadeBig", "settings.fadeFraction", [](auto& s, auto&, auto&) { s.fadeFraction = 1.01; }},
    {"fadeNaN", "settings.fadeFraction", [](auto& s, auto&, auto&) { s.fadeFraction = kNaN; }},
    {"biasNeg", "settings.depthBiasConstant",
     [](auto& s, auto&, auto&) { s.depthBiasConstant = -1; }},
    {"biasInf", "settings.depthBiasConstant",
     [](auto& s, auto&, auto&) { s.depthBiasConstant = std::numeric_limits<float>::infinity(); }},
    {"slopeNaN", "settings.depthBiasSlope",
     [](auto& s, auto&, auto&) { s.depthBiasSlope = std::numeric_limits<float>::quiet_NaN(); }},
    {"offsetNeg", "settings.normalOffsetTexels",
     [](auto& s, auto&, auto&) { s.normalOffsetTexels = -2; }},
    {"offsetBig", "settings.normalOffsetTexels",
     [](auto& s, auto&, auto&) { s.normalOffsetTexels = 17; }},
    {"offsetNaN", "settings.normalOffsetTexels",
     [](auto& s, auto&, auto&) { s.normalOffsetTexels = std::numeric_limits<float>::quiet_NaN(); }},
    {"floorNeg", "settings.depthFloorTexels",
     [](auto& s, auto&, auto&) { s.depthFloorTexels = -0.1f; }},
    {"floorBig", "settings.depthFloorTexels",
     [](auto& s, auto&, auto&) { s.depthFloorTexels = 16.5f; }},
    {"floorNaN", "settings.depthFloorTexels",
     [](auto& s, auto&, auto&) { s.depthFloorTexels = std::numeric_limits<float>::quiet_NaN(); }},
    {"minTexNeg", "settings.minCasterTexels",
     [](auto& s, auto&, auto&) { s.minCasterTexels = -1; }},
    {"lightAngleNeg", "settings.lightAngularDiameterDeg",
     [](auto& s, auto&, auto&) { s.lightAngularDiameterDeg = -0.1; }},
    {"lightAngleBig", "settings.lightAngularDiameterDeg",
     [](auto& s, auto&, auto&) { s.lightAngularDiameterDeg = 20.5; }},
    {"lightAngleNaN", "settings.lightAngularDiameterDeg",
     [](auto& s, auto&, auto&) { s.lightAngularDiameterDeg = kNaN; }},
    {"penumbraNeg", "settings.maxPenumbraM", [](auto& s, auto&, auto&) { s.maxPenumbraM = -1.0; }},
    {"penumbraInf", "settings.maxPenumbraM", [](auto& s, auto&, auto&) { s.maxPenumbraM = kInf; }},
    {"kernelUnknown", "settings.kernel",
     [](auto& s, auto&, auto&) { s.kernel = static_cast<PcfKernel>(CSM_FILTER_COUNT); }},
    {"pcssTaps0", "settings.pcssTaps", [](auto& s, auto&, auto&) { s.pcssTaps = 0; }},
    {"pcssTapsOver", "settings.pcssTaps",
     [](auto& s, auto&, auto&) { s.pcssTaps = CSM_PCSS_MAX_TAPS + 1; }},
    {"posNaN", "camera.positionWs.y", [](auto&, auto& c, auto&) { c.positionWs.y = kNaN; }},
    {"posInf", "camera.positionWs.x", [](auto&, auto& c, auto&) { c.positionWs.x = -kInf; }},
    {"quatZero", "camera.orientationWs (length)",
     [](auto&, auto& c, auto&) { c.orientationWs = glm::dquat(0, 0, 0, 0); }},
    {"quatNaN", "camera.orientationWs (length)",
     [](auto&, auto& c, auto&) { c.orientationWs.x = kNaN; }},
    {"fov0", "camera.fovYRad", [](auto&, auto& c, auto&) { c.fovYRad = 0.0; }},
    {"fovPi", "camera.fovYRad", [](auto&, auto& c, auto&) { c.fovYRad = glm::pi<double>(); }},
    {"aspect0", "camera.aspect", [](auto&, auto& c, auto&) { c.aspect = 0.0; }},
    {"aspectNaN", "camera.aspect", [](auto&, auto& c, auto&) { c.aspect = kNaN; }},
    {"near0", "camera.nearM", [](auto&, auto& c, auto&) { c.nearM = 0.0; }},
    {"nearNeg", "camera.nearM", [](auto&, auto& c, auto&) { c.nearM = -1.0; }},
    {"farBelowNear", "camera.farM", [](auto&, auto& c, auto&) { c.farM = c.nearM; }},
    {"farInf", "camera.farM", [](auto&, auto& c, auto&) { c.farM = kInf; }},
    // The domain where results are exact (types.hpp): refused just beyond each limit.
    {"posBeyondDomain", "camera.positionWs.z",
     [](auto&, auto& c, auto&) { c.positionWs.z = -1.000001e9; }},
    {"nearBelowMin", "camera.nearM", [](auto&, auto& c, auto&) { c.nearM = 0.99e-6; }},
    {"nearTiny", "camera.nearM", [](auto&, auto& c, auto&) { c.nearM = 1e-20; }},
    {"farOverNear", "camera.farM",
     [](auto&, auto& c, auto&) { c.farM = c.nearM * kMaxFarOverNear * 1.001; }},
    {"distBeyondDomain", "settings.shadowDistanceM",
     [](auto& s, auto& c, auto&) {
       c.farM = 1e8;
       s.shadowDistanceM = 1.01e9;
     }},
    {"lightZero", "light.directionWs (length)",
     [](auto&, auto&, auto& l) { l.directionWs = glm::dvec3(0.0); }},
    {"lightNaN", "light.directionWs.z", [](auto&, auto&, auto& l) { l.directionWs.z = kNaN; }},
};

INSTANTIATE_TEST_SUITE_P(AllFields, ValidationTest, ::testing::ValuesIn(kCases),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(Validation, MessageNamesValueAndRange) {
  ShadowSettings s;
  s.resolution = 300;
  const auto e = validate(s);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->message(),
            "settings.resolution = 300 is invalid: allowed a power of two in [256, 16384]");
}

TEST(Validation, SceneBoundsRefused) {
  ShadowSettings s;
  Camera c;
  DirectionalLight l;
  AabbWs inverted{{0, 0, 0}, {1, -1, 1}};
  auto r = computeCascades(s, c, l, &inverted);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "sceneBounds.maxWs.y");
  AabbWs nan{{kNaN, 0, 0}, {1, 1, 1}};
  r = computeCascades(s, c, l, &nan);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "sceneBounds.minWs.x");
}

TEST(Validation, CasterBoundsRefused) {
  CasterSet set;
  auto a = set.addSphere({0, kNaN, 0}, 1.0);
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.error().field, "caster.centerWs[1]");
  a = set.addSphere({0, 0, 0}, -1.0);
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.error().field, "caster.radiusM");
  a = set.addBox({0, 0, 0}, {1, 1, -1});
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.error().field, "caster.maxWs[2]");
  EXPECT_EQ(set.size(), 0u);
}

TEST(Validation, BoundsBeyondTheDomainRefused) {
  ShadowSettings s;
  Camera c;
  DirectionalLight l;
  AabbWs far{{0, 0, 0}, {1, 1, 2e9}};
  auto r = computeCascades(s, c, l, &far);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "sceneBounds.maxWs.z");
  CasterSet set;
  auto a = set.addSphere({-1e300, 0, 0}, 1.0);
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.error().field, "caster.centerWs[0]");
  a = set.addBox({0, 0, 0}, {1, 1.5e9, 1});
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.error().field, "caster.maxWs[1]");
  EXPECT_TRUE(set.addBox(glm::dvec3(-kMaxWorldCoordinateM), glm::dvec3(kMaxWorldCoordinateM)).ok());
  EXPECT_EQ(set.size(), 1u);
}

// Texels too small for the camera's distance from the origin: the snap to the world grid would
// lose its bits below a texel. Refused naming the camera's position and the texel; the same
// settings at the origin, or unstabilised (no snap), are accepted; the history is unchanged.
TEST(Validation, TexelsTooSmallForTheDistanceFromTheOriginRefused) {
  ShadowSettings s;
  s.resolution = 16384;
  s.shadowDistanceM = 2e-6;
  Camera c;
  c.nearM = 1e-6;
  c.farM = 1.0;
  c.fovYRad = glm::radians(1.0);
  DirectionalLight l{{0.3, -1.0, 0.2}};
  CascadeHistory history;
  ASSERT_TRUE(computeCascades(s, c, l, nullptr, &history).ok());
  const std::uint64_t frames = history.frames;
  c.positionWs = {9e8, 0.0, -9e8};
  auto r = computeCascades(s, c, l, nullptr, &history);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "camera.positionWs (distance from the origin)");
  EXPECT_NE(r.error().message().find("texels of"), std::string::npos) << r.error().message();
  EXPECT_EQ(history.frames, frames);
  s.diagnostics.stabilize = false;
  EXPECT_TRUE(computeCascades(s, c, l).ok());
}

TEST(Validation, ValidBoundariesAccepted) {
  ShadowSettings s;
  Camera c;
  DirectionalLight l;
  for (std::uint32_t n : {1u, 8u}) {
    for (std::uint32_t res : {256u, 16384u}) {
      for (double lambda : {0.0, 1.0}) {
        for (double band : {0.0, 0.5}) {
          s.cascadeCount = n;
          s.resolution = res;
          s.splitLambda = lambda;
          s.blendBand = band;
          EXPECT_FALSE(validate(s, c, l).has_value());
        }
      }
    }
  }
  // Every kernel, and the PCSS taps' ends.
  s = ShadowSettings{};
  for (PcfKernel k : kAllKernels) {
    s.kernel = k;
    for (std::uint32_t taps : {1u, std::uint32_t(CSM_PCSS_MAX_TAPS)}) {
      s.pcssTaps = taps;
      EXPECT_FALSE(validate(s, c, l).has_value()) << kernelName(k) << " " << taps;
    }
  }
  // The domain's own limits are inside it.
  s = ShadowSettings{};
  c.positionWs = glm::dvec3(-kMaxWorldCoordinateM, kMaxWorldCoordinateM, kMaxWorldCoordinateM);
  c.nearM = kMinNearM;
  c.farM = kMinNearM * kMaxFarOverNear;
  EXPECT_FALSE(validate(s, c, l).has_value());
}

}  // namespace
}  // namespace csm
