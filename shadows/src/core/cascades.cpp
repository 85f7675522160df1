#include "csm/cascades.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "csm/frustum.hpp"
#include "csm/light_space.hpp"

namespace csm {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::array<glm::dvec3, 8> aabbCorners(const AabbWs& b) noexcept {
  std::array<glm::dvec3, 8> c{};
  for (int i = 0; i < 8; ++i) {
    c[i] = glm::dvec3((i & 1) ? b.maxWs.x : b.minWs.x, (i & 2) ? b.maxWs.y : b.minWs.y,
                      (i & 4) ? b.maxWs.z : b.minWs.z);
  }
  return c;
}

bool sphereTouchesAabb(const glm::dvec3& c, double r, const AabbWs& b) noexcept {
  const glm::dvec3 q = glm::clamp(c, b.minWs, b.maxWs);
  const glm::dvec3 d = c - q;
  return glm::dot(d, d) <= r * r;
}

// Camera-relative world -> shadow clip space. p_Ls = B^T (p_Cr + camera - boxCenter); the
// translation is formed in double from two nearby points, so it is exact far from the origin.
glm::mat4 cameraRelativeViewProj(const glm::dmat3& basis, const glm::dvec3& cameraWs,
                                 const Cascade& c) noexcept {
  const glm::dvec3 t = glm::transpose(basis) * (cameraWs - c.boxCenterWs);
  const double dz = c.depthFarLs - c.depthNearLs;
  const glm::dvec3 scale(1.0 / c.halfExtentLs.x, 1.0 / c.halfExtentLs.y, 1.0 / dz);
  const glm::dvec3 offset(t.x * scale.x, t.y * scale.y, (t.z - c.depthNearLs) * scale.z);
  glm::mat4 m(0.0f);
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) {
      m[col][row] = static_cast<float>(basis[row][col] * scale[row]);
    }
    m[3][row] = static_cast<float>(offset[row]);
  }
  m[3][3] = 1.0f;
  return m;
}

}  // namespace

Result<CascadeFrame> computeCascades(const ShadowSettings& settings, const Camera& camera,
                                     const DirectionalLight& light, const AabbWs* sceneBounds,
                                     CascadeHistory* history) {
  if (auto e = validate(settings, camera, light)) return *e;
  if (sceneBounds != nullptr) {
    if (auto e = validate(*sceneBounds, "sceneBounds")) return *e;
  }

  CascadeFrame frame;
  const std::uint32_t count = settings.cascadeCount;
  frame.cascadeCount = count;
  frame.resolution = settings.resolution;
  frame.blendBand = settings.blendBand;
  frame.normalOffsetTexels = settings.normalOffsetTexels;
  frame.lightDirectionWs = glm::normalize(light.directionWs);
  frame.lightBasisWs = lightBasisWs(frame.lightDirectionWs);
  frame.cameraPositionWs = camera.positionWs;
  const glm::dquat orientation = glm::normalize(camera.orientationWs);
  frame.cameraForwardWs = orientation * glm::dvec3(0.0, 0.0, -1.0);
  const glm::dmat3& basis = frame.lightBasisWs;
  const glm::dmat3 basisT = glm::transpose(basis);

  // Reset the history when what it quantises against has changed.
  const double maxFarM = std::min(settings.shadowDistanceM, camera.farM);
  if (history != nullptr && (history->shadowFarMaxM != maxFarM || history->cascadeCount != count)) {
    *history = CascadeHistory{};
    history->shadowFarMaxM = maxFarM;
    history->cascadeCount = count;
  }

  // How far receivers reach along the view: the scene's depth interval.
  double sceneMinDepthM = -kInf;
  double sceneMaxDepthM = kInf;
  std::array<glm::dvec3, 8> sceneCorners{};
  if (sceneBounds != nullptr) {
    sceneCorners = aabbCorners(*sceneBounds);
    sceneMinDepthM = kInf;
    sceneMaxDepthM = -kInf;
    for (const glm::dvec3& p : sceneCorners) {
      const double d = glm::dot(p - camera.positionWs, frame.cameraForwardWs);
      sceneMinDepthM = std::min(sceneMinDepthM, d);
      sceneMaxDepthM = std::max(sceneMaxDepthM, d);
    }
  }
  const bool sceneAhead = sceneMaxDepthM > camera.nearM;
  // Splits end at the scene's far end, in quantised steps; never closer than 2 x near.
  const double minFarM = std::min(maxFarM, 2.0 * camera.nearM);
  const double neededFarM = sceneAhead ? std::min(maxFarM, sceneMaxDepthM) : maxFarM;
  frame.shadowFarM = quantizedShadowFar(neededFarM, maxFarM, minFarM,
                                        history != nullptr ? history->shadowFarM : 0.0);
  if (history != nullptr) history->shadowFarM = frame.shadowFarM;
  frame.splitsM =
      settings.explicitSplits()
          ? explicitSplits(camera.nearM, frame.shadowFarM, count, settings.splitPositions)
          : practicalSplits(camera.nearM, frame.shadowFarM, count, settings.splitLambda);

  const double res = static_cast<double>(settings.resolution);
  for (std::uint32_t i = 0; i < count; ++i) {
    Cascade& c = frame.cascades[i];
    c.splitNearM = frame.splitsM[i];
    c.splitFarM = frame.splitsM[i + 1];

    const SliceSphere sphere =
        minimalSliceSphere(camera.fovYRad, camera.aspect, c.splitNearM, c.splitFarM);
    c.sphereRadiusM = quantizeLengthUp(sphere.radiusM);
    c.sphereCenterWs = camera.positionWs + frame.cameraForwardWs * sphere.centerDepthM;

    double depthNearLs = 0.0;
    if (settings.stabilize) {
      // A box of whole texels whose half side leaves room for the half-texel snap:
      // h - texel / 2 >= r  <=>  h >= r * res / (res - 1).
      const double half = quantizeLengthUp(c.sphereRadiusM * res / (res - 1.0));
      const double texel = 2.0 * half / res;
      c.halfExtentLs = glm::dvec2(half);
      c.texelSizeLs = glm::dvec2(texel);
      // Snap the centre on the light-space grid anchored at the world origin, in double.
      const glm::dvec3 centerLs = basisT * c.sphereCenterWs;
      const glm::dvec3 snappedLs(std::round(centerLs.x / texel) * texel,
                                 std::round(centerLs.y / texel) * texel, centerLs.z);
      c.boxCenterWs = basis * snappedLs;
      // Make the box centre's depth exactly the sphere centre's (only x, y are snapped).
      c.boxCenterWs += basis[2] * (centerLs.z - glm::dot(basis[2], c.boxCenterWs));
      c.depthFarLs = c.sphereRadiusM;
      depthNearLs = -c.sphereRadiusM;
    } else {
      // Tight fit to the slice's light-space bounds; no snapping (the comparison mode).
      const auto corners = sliceCornersCr(camera, c.splitNearM, c.splitFarM);
      glm::dvec3 lo(kInf), hi(-kInf);
      for (const glm::dvec3& p : corners) {
        const glm::dvec3 q = basisT * p;
        lo = glm::min(lo, q);
        hi = glm::max(hi, q);
      }
      const glm::dvec3 centerLs = 0.5 * (lo + hi);
      c.boxCenterWs = camera.positionWs + basis * centerLs;
      c.halfExtentLs = glm::max(glm::dvec2(0.5 * (hi - lo)), glm::dvec2(1e-9));
      c.texelSizeLs = 2.0 * c.halfExtentLs / res;
      c.depthFarLs = std::max(0.5 * (hi.z - lo.z), 1e-9);
      depthNearLs = -c.depthFarLs;
    }

    // Extend the depth range toward the light over the scene's casters, in steps of a quarter
    // of the box's depth, keeping last frame's extension while it still covers (hysteresis).
    if (sceneBounds != nullptr) {
      double sceneNearLs = kInf;
      for (const glm::dvec3& p : sceneCorners) {
        sceneNearLs = std::min(sceneNearLs, glm::dot(basis[2], p - c.boxCenterWs));
      }
      if (sceneNearLs < depthNearLs) {
        const double step = 0.5 * c.depthFarLs;
        const double needed = -std::ceil(-sceneNearLs / step) * step;
        depthNearLs = needed;
        if (history != nullptr) {
          const double previous = history->depthNearLs[i];
          if (previous <= sceneNearLs && previous >= needed - 2.0 * step) depthNearLs = previous;
        }
      }
    }
    if (history != nullptr) history->depthNearLs[i] = depthNearLs;
    c.depthNearLs = depthNearLs;

    // Empty: no receiver of the scene lies in this slice.
    c.empty = !sceneAhead;
    if (sceneBounds != nullptr && !c.empty) {
      c.empty = !(c.splitFarM > sceneMinDepthM && c.splitNearM < sceneMaxDepthM) ||
                !sphereTouchesAabb(c.sphereCenterWs, c.sphereRadiusM, *sceneBounds);
    }
    c.viewProjCr = cameraRelativeViewProj(basis, camera.positionWs, c);
  }
  return frame;
}

glm::dvec3 shadowTexelCoord(const Cascade& cascade, const CascadeFrame& frame,
                            const glm::dvec3& posWs) noexcept {
  const glm::dvec3 p = toLightSpace(frame.lightBasisWs, cascade.boxCenterWs, posWs);
  const double res = static_cast<double>(frame.resolution);
  return {(p.x / cascade.halfExtentLs.x * 0.5 + 0.5) * res,
          (p.y / cascade.halfExtentLs.y * 0.5 + 0.5) * res,
          (p.z - cascade.depthNearLs) / (cascade.depthFarLs - cascade.depthNearLs)};
}

}  // namespace csm
