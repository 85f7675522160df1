// Far-field flicker against the pixel-coverage truth (see flicker.hpp).
#include "csm_measure/flicker.hpp"

#include <algorithm>
#include <cmath>

#include "csm_measure/metrics.hpp"

namespace csm_measure {

glm::dvec3 cameraRayWs(const csm::Camera& camera, VkExtent2D extent, double px, double py) {
  const double tanHalf = std::tan(0.5 * camera.fovYRad);
  const double ndcX = 2.0 * px / double(extent.width) - 1.0;
  const double ndcY = 2.0 * py / double(extent.height) - 1.0;  // y down
  const glm::dvec3 dirCam(ndcX * tanHalf * camera.aspect, -ndcY * tanHalf, -1.0);
  return glm::normalize(camera.orientationWs * dirCam);
}

std::vector<float> pixelCoverageTruth(const RayTracer& tracer, const csm::Camera& camera,
                                      VkExtent2D extent, const csm::DirectionalLight& light,
                                      std::span<const PixelSample> pixels,
                                      const csm::CascadeFrame& frame, const FlickerOptions& o) {
  const size_t count = size_t(extent.width) * extent.height;
  std::vector<float> truth(count, -1.0f);
  std::vector<const PixelSample*> at(count, nullptr);
  for (const PixelSample& p : pixels) {
    if (p.x < extent.width && p.y < extent.height) at[size_t(p.y) * extent.width + p.x] = &p;
  }
  const glm::dvec3 toLight = -glm::normalize(light.directionWs);
  const int n = std::max(o.subsamples, 1);
  auto work = [&](size_t begin, size_t end) {
    std::vector<glm::dvec3> pos(size_t(n) * n);
    std::vector<glm::vec3> nrm(size_t(n) * n);
    std::vector<float> vis(size_t(n) * n);
    for (size_t i = begin; i < end; ++i) {
      const PixelSample* p = at[i];
      if (!p || p->cascade < o.minCascade || !std::isfinite(p->shadow)) continue;
      const double centreDist = glm::length(p->posWs - camera.positionWs);
      if (!(centreDist > 0.0) || !std::isfinite(centreDist)) continue;
      const double x = double(i % extent.width), y = double(i / extent.width);
      bool ok = true;
      for (int sy = 0; sy < n && ok; ++sy) {
        for (int sx = 0; sx < n && ok; ++sx) {
          const glm::dvec3 dir =
              cameraRayWs(camera, extent, x + (sx + 0.5) / n, y + (sy + 0.5) / n);
          glm::dvec3 hit;
          glm::vec3 normal;
          if (!tracer.intersect(camera.positionWs, dir, &hit, &normal)) {
            ok = false;  // the sky
            break;
          }
          const double normalLength = glm::length(glm::dvec3(normal));
          if (!(normalLength > 0.0) || !std::isfinite(normalLength)) {
            ok = false;  // a degenerate triangle: no side faces the light
            break;
          }
          glm::dvec3 nd = glm::dvec3(normal) / normalLength;
          if (glm::dot(nd, dir) > 0.0) nd = -nd;  // the side the camera sees
          const double d = glm::length(hit - camera.positionWs);
          if (!(std::abs(d - centreDist) <= o.continuity * centreDist) ||
              glm::dot(nd, toLight) <= 0.0) {
            ok = false;
            break;
          }
          const size_t k = size_t(sy) * n + sx;
          pos[k] = hit;
          nrm[k] = glm::vec3(nd);
        }
      }
      if (!ok) continue;
      tracer.visibility(pos, nrm, light.directionWs, vis);
      double lit = 0.0;
      for (float v : vis) lit += v;
      truth[i] = float(fadedTruth(lit / double(vis.size()), *p, frame));
    }
  };
  parallelChunks(count, 16u, work);
  return truth;
}

nlohmann::json FlickerStats::toJson() const {
  return {{"pairs", pairs},
          {"stable_pairs", stablePairs},
          {"flickering", flickering},
          {"far_flicker", rate()},
          {"excess", excess},
          {"excess_rate", excessRate()},
          {"mean_render_change", meanRenderChange()},
          {"mean_truth_change", stablePairs ? truthChangeSum / double(stablePairs) : 0.0},
          {"max_render_change", maxRenderChange},
          {"non_finite", nonFinite}};
}

void accumulateFlicker(FlickerStats& stats, VkExtent2D extent, std::span<const PixelSample> a,
                       std::span<const float> truthA, std::span<const PixelSample> b,
                       std::span<const float> truthB, const FlickerOptions& o) {
  const size_t count = size_t(extent.width) * extent.height;
  auto index = [&](std::span<const PixelSample> pixels) {
    std::vector<const PixelSample*> at(count, nullptr);
    for (const PixelSample& p : pixels) {
      if (p.x < extent.width && p.y < extent.height) at[size_t(p.y) * extent.width + p.x] = &p;
    }
    return at;
  };
  const std::vector<const PixelSample*> atA = index(a), atB = index(b);
  for (size_t i = 0; i < count && i < truthA.size() && i < truthB.size(); ++i) {
    if (truthA[i] < 0.0f || truthB[i] < 0.0f || !atA[i] || !atB[i]) continue;
    if (atA[i]->cascade < o.minCascade || atB[i]->cascade < o.minCascade) continue;
    const double fa = atA[i]->shadow, fb = atB[i]->shadow;
    if (!std::isfinite(fa) || !std::isfinite(fb)) {
      ++stats.nonFinite;
      continue;
    }
    ++stats.pairs;
    const double dF = std::abs(fb - fa);
    const double dT = std::abs(double(truthB[i]) - double(truthA[i]));
    if (dF - dT > o.visibleChange) ++stats.excess;
    if (dT > o.stableTruth) continue;
    ++stats.stablePairs;
    stats.renderChangeSum += dF;
    stats.truthChangeSum += dT;
    stats.maxRenderChange = std::max(stats.maxRenderChange, dF);
    if (dF > o.visibleChange) ++stats.flickering;
  }
}

}  // namespace csm_measure
