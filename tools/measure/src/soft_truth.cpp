// Soft-shadow truth (see soft_truth.hpp).
#include "csm_measure/soft_truth.hpp"

#include <csm/light_space.hpp>
#include <csm/selection.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>

#include "csm_measure/metrics.hpp"

namespace csm_measure {
namespace {

// Shirley-Chiu concentric map of the square [-1, 1]^2 onto the unit disk (area-preserving).
glm::dvec2 concentric(double a, double b) noexcept {
  if (a == 0.0 && b == 0.0) return glm::dvec2(0.0);
  const double quarterPi = 0.25 * glm::pi<double>();
  if (std::abs(a) > std::abs(b)) {
    const double phi = quarterPi * (b / a);
    return a * glm::dvec2(std::cos(phi), std::sin(phi));
  }
  const double phi = 2.0 * quarterPi - quarterPi * (a / b);
  return b * glm::dvec2(std::cos(phi), std::sin(phi));
}

bool finiteAndFacing(const PixelSample& p, const glm::dvec3& toLight) noexcept {
  const bool finite = std::isfinite(p.shadow) && std::isfinite(p.posWs.x) &&
                      std::isfinite(p.posWs.y) && std::isfinite(p.posWs.z) &&
                      std::isfinite(p.normalWs.x) && std::isfinite(p.normalWs.y) &&
                      std::isfinite(p.normalWs.z);
  return finite && glm::dot(glm::dvec3(p.normalWs), toLight) > 0.0;
}

bool comparable(const PixelSample& p, const csm::CascadeFrame& frame,
                const glm::dvec3& toLight) noexcept {
  return finiteAndFacing(p, toLight) && p.cascade >= 0 && p.cascade < int(frame.cascadeCount);
}

}  // namespace

std::vector<glm::dvec3> sunDiskDirections(const glm::dvec3& lightDirWs, double angularDiameterDeg,
                                          int strataPerAxis) {
  const glm::dmat3 basis = csm::lightBasisWs(lightDirWs);
  const double tanRadius = std::tan(glm::radians(0.5 * angularDiameterDeg));
  std::mt19937 rng(0x50f7u);
  std::uniform_real_distribution<double> jitter(0.0, 1.0);
  const int n = std::max(strataPerAxis, 1);
  std::vector<glm::dvec3> dirs;
  dirs.reserve(size_t(n) * size_t(n));
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const double a = 2.0 * (i + jitter(rng)) / n - 1.0;
      const double b = 2.0 * (j + jitter(rng)) / n - 1.0;
      const glm::dvec2 d = concentric(a, b) * tanRadius;
      dirs.push_back(glm::normalize(basis[2] + d.x * basis[0] + d.y * basis[1]));
    }
  }
  return dirs;
}

void softVisibility(const RayTracer& tracer, std::span<const glm::dvec3> posWs,
                    std::span<const glm::vec3> normalWs, const glm::dvec3& lightDirWs,
                    double angularDiameterDeg, std::span<float> out, int strataPerAxis) {
  const std::vector<glm::dvec3> dirs =
      sunDiskDirections(lightDirWs, angularDiameterDeg, strataPerAxis);
  const size_t count = posWs.size();
  auto work = [&](size_t begin, size_t end) {
    std::vector<float> vis(end - begin);
    std::vector<double> sum(end - begin, 0.0);
    for (const glm::dvec3& d : dirs) {
      tracer.visibility(posWs.subspan(begin, end - begin), normalWs.subspan(begin, end - begin), d,
                        vis);
      for (size_t k = 0; k < vis.size(); ++k) sum[k] += vis[k];
    }
    for (size_t k = 0; k < vis.size(); ++k) out[begin + k] = float(sum[k] / double(dirs.size()));
  };
  parallelChunks(count, 8u, work);
}

nlohmann::json SoftErrorStats::toJson() const {
  return {{"pixels", pixels},
          {"mean_abs_err", meanAbsError()},
          {"penumbra_pixels", penumbraPixels},
          {"penumbra_mean_abs_err", penumbraMeanAbsError()},
          {"non_finite", nonFinite}};
}

namespace {

std::vector<float> softTruthWhere(std::span<const PixelSample> pixels, const RayTracer& tracer,
                                  const csm::DirectionalLight& light, double angularDiameterDeg,
                                  const std::function<bool(const PixelSample&)>& compared) {
  std::vector<glm::dvec3> pos;
  std::vector<glm::vec3> nrm;
  std::vector<size_t> index;
  for (size_t i = 0; i < pixels.size(); ++i) {
    if (!compared(pixels[i])) continue;
    pos.push_back(pixels[i].posWs);
    nrm.push_back(pixels[i].normalWs);
    index.push_back(i);
  }
  std::vector<float> vis(pos.size());
  softVisibility(tracer, pos, nrm, light.directionWs, angularDiameterDeg, vis);
  std::vector<float> truth(pixels.size(), -1.0f);
  for (size_t k = 0; k < index.size(); ++k) truth[index[k]] = vis[k];
  return truth;
}

}  // namespace

std::vector<float> softTruthOfPixels(std::span<const PixelSample> pixels,
                                     const csm::CascadeFrame& frame, const RayTracer& tracer,
                                     const csm::DirectionalLight& light,
                                     double angularDiameterDeg) {
  const glm::dvec3 toLight = -glm::normalize(light.directionWs);
  std::vector<float> truth =
      softTruthWhere(pixels, tracer, light, angularDiameterDeg,
                     [&](const PixelSample& p) { return comparable(p, frame, toLight); });
  // Toward the shadow distance the module fades to lit by design (ShadowSettings::fadeFraction):
  // the truth there is the faded one.
  for (size_t i = 0; i < pixels.size(); ++i) {
    if (truth[i] >= 0.0f) truth[i] = float(fadedTruth(truth[i], pixels[i], frame));
  }
  return truth;
}

std::vector<float> softTruthOfReceivers(std::span<const PixelSample> pixels,
                                        const RayTracer& tracer, const csm::DirectionalLight& light,
                                        double angularDiameterDeg) {
  const glm::dvec3 toLight = -glm::normalize(light.directionWs);
  return softTruthWhere(pixels, tracer, light, angularDiameterDeg,
                        [&](const PixelSample& p) { return finiteAndFacing(p, toLight); });
}

SoftErrorStats measureSoftError(std::span<const PixelSample> pixels, std::span<const float> truth) {
  SoftErrorStats st;
  for (size_t i = 0; i < pixels.size() && i < truth.size(); ++i) {
    if (truth[i] < 0.0f) continue;
    if (!std::isfinite(pixels[i].shadow)) {
      ++st.nonFinite;
      continue;
    }
    const double s = std::clamp(double(pixels[i].shadow), 0.0, 1.0);
    const double e = std::abs(s - double(truth[i]));
    ++st.pixels;
    st.absErrorSum += e;
    if (truth[i] > 0.02f && truth[i] < 0.98f) {
      ++st.penumbraPixels;
      st.penumbraAbsErrorSum += e;
    }
  }
  return st;
}

double penumbraWidth10to90(std::span<const float> profile, double stepM) noexcept {
  size_t below10 = 0, below90 = 0;
  for (float v : profile) {
    if (v < 0.1f) ++below10;
    if (v < 0.9f) ++below90;
  }
  return double(below90 - below10) * stepM;
}

}  // namespace csm_measure
