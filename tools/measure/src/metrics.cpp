// The numbers (see metrics.hpp).
#include "csm_measure/metrics.hpp"

#include <csm/selection.hpp>
#include <glue/camera.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <thread>

namespace csm_measure {
namespace {

bool finite(const glm::mat4& m) noexcept {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

// Inside the view frustum of `camera` (clip-space test in double).
struct FrustumTest {
  glm::dmat4 viewProjCr;
  glm::dvec3 cameraWs;
  explicit FrustumTest(const csm::Camera& c)
      : viewProjCr(glm::dmat4(glue::toEngineCamera(c).viewProjectionCr())),
        cameraWs(c.positionWs) {}
  bool inside(const glm::dvec3& posWs) const noexcept {
    const glm::dvec4 p = viewProjCr * glm::dvec4(posWs - cameraWs, 1.0);
    return p.w > 0.0 && std::abs(p.x) <= p.w && std::abs(p.y) <= p.w && p.z >= 0.0 && p.z <= p.w;
  }
};

}  // namespace

void ShimmerStats::add(double d) noexcept {
  ++pairs;
  sum += d;
  max = std::max(max, d);
  if (d > kVisibleStep) ++visible;
}

void ShimmerStats::merge(const ShimmerStats& o) noexcept {
  pairs += o.pairs;
  visible += o.visible;
  sum += o.sum;
  max = std::max(max, o.max);
}

nlohmann::json ShimmerStats::toJson() const {
  return {{"pairs", pairs},
          {"mean", mean()},
          {"max", max},
          {"fraction_above_1_255", visibleFraction()}};
}

void ShimmerClasses::merge(const ShimmerClasses& o) noexcept {
  stayed.merge(o.stayed);
  band.merge(o.band);
  crossed.merge(o.crossed);
}

nlohmann::json ShimmerClasses::toJson() const {
  return {{"stayed", stayed.toJson()}, {"band", band.toJson()}, {"crossed", crossed.toJson()}};
}

nlohmann::json ShimmerRun::toJson(bool perFrameSeries) const {
  nlohmann::json j = total.toJson();
  j["points_tracked"] = pointsTracked;
  j["non_finite"] = nonFinite;
  nlohmann::json changes = nlohmann::json::array();
  for (const Change& c : visibleChanges) {
    changes.push_back({{"frame", c.frame},
                       {"receiver", c.receiver},
                       {"delta", c.delta},
                       {"min_depth_gap_m", c.depthGapM},
                       {"before", c.before},
                       {"after", c.after},
                       {"cascade", c.cascade}});
  }
  j["stayed_visible_changes"] = changes;
  if (perFrameSeries) {
    nlohmann::json mean = nlohmann::json::array(), max = nlohmann::json::array(),
                   frac = nlohmann::json::array(), crossedMean = nlohmann::json::array();
    for (const ShimmerClasses& f : perFrame) {
      mean.push_back(f.stayed.mean());
      max.push_back(f.stayed.max);
      frac.push_back(f.stayed.visibleFraction());
      crossedMean.push_back(f.crossed.mean());
    }
    j["per_frame"] = {{"stayed_mean", mean},
                      {"stayed_max", max},
                      {"stayed_fraction_above_1_255", frac},
                      {"crossed_mean", crossedMean}};
  }
  return j;
}

namespace {

/// Where `posWs` lands on a screen of kScreenHeight pixels (and camera.aspect times as wide):
/// the pixel a lighting shader at the fly-through's 1280 x 720 would shade it in. Points behind
/// the camera get (0, 0).
glm::vec2 screenPixel(const csm::Camera& camera, const glm::dvec3& posWs) {
  constexpr double kScreenHeight = 720.0;
  const glm::dvec3 c = glm::conjugate(camera.orientationWs) * (posWs - camera.positionWs);
  if (!(c.z < 0.0)) return glm::vec2(0.0f);
  const double t = std::tan(0.5 * camera.fovYRad);
  const double x = c.x / (-c.z * t * camera.aspect), y = c.y / (-c.z * t);
  return glm::vec2(
      glm::dvec2(0.5 * (x + 1.0) * kScreenHeight * camera.aspect, 0.5 * (1.0 - y) * kScreenHeight));
}

}  // namespace

ShimmerRun measureShimmer(Harness& harness, std::span<const Receiver> receivers,
                          const csm::DirectionalLight& light, const CameraPath& path, int frames,
                          csm::PcfKernel kernel, bool blend) {
  ShimmerRun run;
  csm::CascadeHistory history;
  std::vector<ProbeResult> previous;
  std::vector<uint8_t> previousInside;
  csm::CascadeFrame previousFrame;
  for (int f = 0; f < frames; ++f) {
    const csm::Camera camera = path(f);
    const csm::CascadeFrame frame = harness.computeFrame(camera, light, history);
    if (!frameIsFinite(frame)) ++run.nonFinite;
    // Each receiver's screen pixel in this frame: a filter whose noise followed the screen
    // (rather than the world) would change under camera motion and count as shimmer.
    std::vector<glm::vec2> pixels(receivers.size());
    for (size_t i = 0; i < receivers.size(); ++i)
      pixels[i] = screenPixel(camera, receivers[i].posWs);
    std::vector<ProbeResult> now = harness.probe(frame, receivers, kernel, blend, pixels);
    const FrustumTest frustum(camera);
    std::vector<uint8_t> inside(receivers.size());
    for (size_t i = 0; i < receivers.size(); ++i) {
      inside[i] = frustum.inside(receivers[i].posWs) ? 1 : 0;
      if (!std::isfinite(now[i].shadow) || !std::isfinite(now[i].blendWeight)) ++run.nonFinite;
    }
    if (f == 0) {
      for (uint8_t v : inside) run.pointsTracked += v;
    } else {
      ShimmerClasses cls;
      for (size_t i = 0; i < receivers.size(); ++i) {
        if (!inside[i] || !previousInside[i]) continue;
        const ProbeResult& a = previous[i];
        const ProbeResult& b = now[i];
        if (a.cascade < 0 && b.cascade < 0) continue;  // beyond the shadows in both frames
        const double d = std::abs(double(b.shadow) - double(a.shadow));
        if (a.cascade != b.cascade) {
          cls.crossed.add(d);
        } else if (a.blendCascade >= 0 || b.blendCascade >= 0 ||
                   csm::shadowFade(previousFrame, a.viewDepthM) > 0.0 ||
                   csm::shadowFade(frame, b.viewDepthM) > 0.0) {
          // Across a blend band, or in the fade to lit before the shadow distance (both follow
          // the camera's view depth, not the texel grid).
          cls.band.add(d);
        } else {
          cls.stayed.add(d);
          if (d > kVisibleStep && run.visibleChanges.size() < 100) {
            run.visibleChanges.push_back(
                {f, i, d, std::min(a.depthGapM, b.depthGapM), a.shadow, b.shadow, b.cascade});
          }
        }
      }
      run.total.merge(cls);
      run.perFrame.push_back(cls);
    }
    previous = std::move(now);
    previousInside = std::move(inside);
    previousFrame = frame;
  }
  return run;
}

void AccuracyBucket::add(double s, double v) noexcept {
  ++pixels;
  const double e = std::abs(s - v);
  absErrorSum += e;
  if (e > 0.5) ++misclassified;
  if (v < 0.5) ++shadowedTruth;
}

nlohmann::json AccuracyBucket::toJson() const {
  return {{"pixels", pixels},
          {"misclassified", misclassified},
          {"shadowed_by_truth", shadowedTruth},
          {"misclassification_rate", rate()},
          {"mean_abs_error", meanAbsError()}};
}

void RatioHistogram::add(double ratio) noexcept {
  if (!(ratio > 0.0) || !std::isfinite(ratio)) return;
  const int k = std::clamp(int(std::floor(std::log2(ratio))) - kLo, 0, kBins - 1);
  ++counts[size_t(k)];
}

nlohmann::json RatioHistogram::toJson() const {
  nlohmann::json bins = nlohmann::json::array();
  for (int k = 0; k < kBins; ++k) {
    bins.push_back(
        {{"log2_from", kLo + k}, {"log2_to", kLo + k + 1}, {"count", counts[size_t(k)]}});
  }
  return bins;
}

void AccuracyStats::merge(const AccuracyStats& o) noexcept {
  auto m = [](AccuracyBucket& a, const AccuracyBucket& b) {
    a.pixels += b.pixels;
    a.misclassified += b.misclassified;
    a.shadowedTruth += b.shadowedTruth;
    a.absErrorSum += b.absErrorSum;
  };
  m(overall, o.overall);
  for (size_t i = 0; i < perCascade.size(); ++i) m(perCascade[i], o.perCascade[i]);
  m(outside, o.outside);
  for (size_t k = 0; k < texelToPixel.counts.size(); ++k)
    texelToPixel.counts[k] += o.texelToPixel.counts[k];
  backFacing += o.backFacing;
  nonFinite += o.nonFinite;
}

nlohmann::json AccuracyStats::toJson(uint32_t cascadeCount) const {
  nlohmann::json per = nlohmann::json::array();
  for (uint32_t i = 0; i < cascadeCount && i < perCascade.size(); ++i)
    per.push_back(perCascade[i].toJson());
  return {{"overall", overall.toJson()},
          {"per_cascade", per},
          {"beyond_shadow_range", outside.toJson()},
          {"back_facing_pixels", backFacing},
          {"non_finite", nonFinite},
          {"texel_to_pixel_log2_histogram", texelToPixel.toJson()}};
}

namespace {

// The pixels measureAccuracy judges (finite outputs, interpolated normal facing the light) and
// their truth: positions, normals, indices into the pixels, shadow-ray visibility.
struct JudgedPixels {
  std::vector<glm::dvec3> pos;
  std::vector<glm::vec3> nrm;
  std::vector<size_t> index;
  std::vector<float> vis;
  uint64_t nonFinite = 0;
  uint64_t backFacing = 0;
};

JudgedPixels judgedPixels(std::span<const PixelSample> pixels, const RayTracer& tracer,
                          const csm::DirectionalLight& light) {
  JudgedPixels j;
  const glm::dvec3 toLight = -glm::normalize(light.directionWs);
  for (size_t i = 0; i < pixels.size(); ++i) {
    const PixelSample& p = pixels[i];
    const bool ok = std::isfinite(p.shadow) && std::isfinite(p.footprintM) &&
                    std::isfinite(p.blendWeight) && std::isfinite(p.posWs.x) &&
                    std::isfinite(p.posWs.y) && std::isfinite(p.posWs.z) &&
                    std::isfinite(p.normalWs.x) && std::isfinite(p.normalWs.y) &&
                    std::isfinite(p.normalWs.z) && p.cascade >= -1;
    if (!ok) {
      ++j.nonFinite;
      continue;
    }
    if (!(glm::dot(glm::dvec3(p.normalWs), toLight) > 0.0)) {
      ++j.backFacing;
      continue;
    }
    j.pos.push_back(p.posWs);
    j.nrm.push_back(p.normalWs);
    j.index.push_back(i);
  }
  j.vis.resize(j.pos.size());
  tracer.visibility(j.pos, j.nrm, light.directionWs, j.vis);
  return j;
}

bool inShadowRange(const PixelSample& p, const csm::CascadeFrame& frame) noexcept {
  return p.cascade >= 0 && p.cascade < int(frame.cascadeCount);
}

}  // namespace

void parallelChunks(size_t count, unsigned maxThreads,
                    const std::function<void(size_t, size_t)>& work) {
  const unsigned threads =
      std::max(1u, std::min(std::max(maxThreads, 1u), std::thread::hardware_concurrency()));
  std::vector<std::thread> pool;
  const size_t chunk = (count + threads - 1) / threads;
  for (unsigned t = 0; t < threads; ++t) {
    const size_t begin = std::min(count, t * chunk);
    const size_t end = std::min(count, begin + chunk);
    if (begin < end) pool.emplace_back(work, begin, end);
  }
  for (std::thread& t : pool) t.join();
}

double fadedTruth(double visibility, const PixelSample& p,
                  const csm::CascadeFrame& frame) noexcept {
  const double fade = csm::shadowFade(frame, csm::viewDepthM(frame, p.posWs));
  return visibility + fade * (1.0 - visibility);
}

AccuracyStats measureAccuracy(std::span<const PixelSample> pixels, const csm::CascadeFrame& frame,
                              const RayTracer& tracer, const csm::DirectionalLight& light) {
  AccuracyStats st;
  const JudgedPixels j = judgedPixels(pixels, tracer, light);
  st.nonFinite = j.nonFinite;
  st.backFacing = j.backFacing;
  const std::vector<float>& vis = j.vis;
  for (size_t k = 0; k < j.index.size(); ++k) {
    const PixelSample& p = pixels[j.index[k]];
    const double s = std::clamp(double(p.shadow), 0.0, 1.0);
    if (!inShadowRange(p, frame)) {
      st.outside.add(s, vis[k]);
      continue;
    }
    const double v = fadedTruth(vis[k], p, frame);
    st.overall.add(s, v);
    st.perCascade[size_t(p.cascade)].add(s, v);
    if (p.footprintM > 0.0f) {
      st.texelToPixel.add(frame.cascades[size_t(p.cascade)].texelSizeM() / double(p.footprintM));
    }
  }
  return st;
}

uint64_t MissCauses::sharedWith(const MissCauses& other) const {
  std::vector<std::pair<uint32_t, uint32_t>> both;
  std::set_intersection(pixels.begin(), pixels.end(), other.pixels.begin(), other.pixels.end(),
                        std::back_inserter(both));
  return both.size();
}

nlohmann::json MissCauses::toJson() const {
  return {{"total", total()},
          {"facing_away_geometrically", facingAway},
          {"false_shadow", falseShadow},
          {"missed_thin_occluder", missedThin},
          {"missed_contact", missedContact},
          {"missed_far", missedFar},
          {"thin_chord_m", kThinChordM},
          {"contact_m", kContactM}};
}

MissCauses classifyMisses(std::span<const PixelSample> pixels, const csm::CascadeFrame& frame,
                          const RayTracer& tracer, const csm::DirectionalLight& light,
                          const glm::dvec3& cameraWs) {
  MissCauses m;
  const glm::dvec3 toLight = -glm::normalize(light.directionWs);
  const JudgedPixels j = judgedPixels(pixels, tracer, light);
  for (size_t k = 0; k < j.index.size(); ++k) {
    const PixelSample& p = pixels[j.index[k]];
    const double s = std::clamp(double(p.shadow), 0.0, 1.0);
    if (!inShadowRange(p, frame) || std::abs(s - fadedTruth(j.vis[k], p, frame)) <= 0.5) continue;
    m.pixels.emplace_back(p.x, p.y);
    // The face the pixel centre's camera ray meets, oriented toward the camera.
    const glm::dvec3 view = glm::normalize(p.posWs - cameraWs);
    glm::vec3 faceN(0.0f);
    if (tracer.intersect(cameraWs, view, nullptr, &faceN)) {
      glm::dvec3 n(faceN);
      if (glm::dot(n, view) > 0.0) n = -n;
      if (!(glm::dot(n, toLight) > 0.0)) {
        ++m.facingAway;
        continue;
      }
    }
    if (fadedTruth(j.vis[k], p, frame) > 0.5) {
      ++m.falseShadow;
      continue;
    }
    // The shadow ray as measureAccuracy casts it (same lift), its first occluder, and that
    // occluder's exit: a hit whose face turns the other way along the ray than the entry's.
    const glm::dvec3 origin =
        p.posWs + RayTracer::kDefaultLiftM * (glm::dvec3(p.normalWs) + toLight);
    glm::dvec3 entry(0.0);
    glm::vec3 entryN(0.0f);
    if (!tracer.intersect(origin, toLight, &entry, &entryN)) {
      ++m.missedFar;  // the occlusion query hit an edge the nearest-hit query missed
      continue;
    }
    const double entryT = glm::dot(entry - origin, toLight);
    double chord = std::numeric_limits<double>::infinity();
    glm::dvec3 exit(0.0);
    glm::vec3 exitN(0.0f);
    if (tracer.intersect(entry + 1e-3 * toLight, toLight, &exit, &exitN) &&
        (glm::dot(glm::dvec3(exitN), toLight) > 0.0) !=
            (glm::dot(glm::dvec3(entryN), toLight) > 0.0)) {
      chord = glm::dot(exit - entry, toLight);
    }
    if (chord < MissCauses::kThinChordM) {
      ++m.missedThin;
    } else if (entryT < MissCauses::kContactM) {
      ++m.missedContact;
    } else {
      ++m.missedFar;
    }
  }
  std::sort(m.pixels.begin(), m.pixels.end());
  return m;
}

bool frameIsFinite(const csm::CascadeFrame& frame) noexcept {
  for (uint32_t i = 0; i < frame.cascadeCount; ++i) {
    const csm::Cascade& c = frame.cascades[i];
    if (!finite(c.viewProjCr)) return false;
    const double v[] = {c.splitNearM,     c.splitFarM,     c.sphereRadiusM, c.halfExtentLs.x,
                        c.halfExtentLs.y, c.texelSizeLs.x, c.depthNearLs,   c.depthFarLs,
                        c.boxCenterWs.x,  c.boxCenterWs.y, c.boxCenterWs.z};
    for (double x : v)
      if (!std::isfinite(x)) return false;
  }
  return std::isfinite(frame.shadowFarM);
}

bool runGnuplot(const std::string& scriptPath, const std::string& script) {
  {
    std::ofstream out(scriptPath);
    out << script;
    if (!out) {
      std::fprintf(stderr, "cannot write %s\n", scriptPath.c_str());
      return false;
    }
  }
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
    std::fprintf(stderr, "gnuplot not found (tools/setup.sh installs gnuplot-nox); no plot\n");
    return false;
  }
  const std::string cmd = "gnuplot '" + scriptPath + "'";
  if (std::system(cmd.c_str()) != 0) {
    std::fprintf(stderr, "gnuplot failed on %s\n", scriptPath.c_str());
    return false;
  }
  return true;
}

void writeJson(const std::string& path, const nlohmann::json& value) {
  const std::filesystem::path p(path);
  if (p.has_parent_path()) std::filesystem::create_directories(p.parent_path());
  std::ofstream out(path);
  out << value.dump(2) << "\n";
  if (!out) throw std::runtime_error("cannot write " + path);
}

}  // namespace csm_measure
