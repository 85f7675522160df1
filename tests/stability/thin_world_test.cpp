// The sample world's thin casters against the ray-traced truth: the power line's 3 cm cables and
// the fences' 6 cm rails, as the fly-through draws them (its shadow settings and sun, its
// "thin" clusters flagged CasterInstance::thin), with the widening off, at half a
// texel (the default before issue 24) and at one texel (the fly-through's before it).
// Receivers are where the centre lines of the cables and rails cast their shadow on the terrain
// (Embree: the ray from the caster's centre along the light); a receiver is lost when it reads
// shaded > 0.5 where the truth is 0. Per caster class and cascade, tent 3x3 (the fly-through's
// kernel) and 1 tap. Writes test_artefacts/stability/thin_world.json.
#include <sample_world/settings.hpp>
#include <sample_world/world.hpp>

#include <cmath>
#include <cstdio>
#include <map>
#include <tuple>

#include <csm_measure/world_scene.hpp>
#include <engine/camera.hpp>

#include "small_world.hpp"
#include "stability_common.hpp"

namespace csm_stability {
namespace {

struct Sample {
  csm_measure::Receiver receiver;
  int cls = 0;  // 0 cable, 1 fence rail
};

const char* const kClassNames[] = {"cable 3 cm", "fence rail 6 cm"};

/// A camera at `eye` looking at `target` with the fly-through's field of view.
csm::Camera cameraAt(const glm::dvec3& eye, const glm::dvec3& target) {
  engine::Camera e;
  e.positionWs = eye;
  e.lookAt(target);
  e.fovYRad = glm::radians(60.0);
  e.aspect = 16.0 / 9.0;
  e.nearM = 0.1;
  e.farM = 5000.0;
  return glue::toCsmCamera(e);
}

TEST(StabilityThinCasters, SampleWorldCablesAndFencesKeepTheirShadowWhenFlagged) {
  nlohmann::json report;
  report["runs"] = nlohmann::json::array();
  {
    CSM_MAKE_HARNESS(harness);
    if (!harness->context().features().geometryShader) {
      GTEST_SKIP() << "no geometryShader: thin casters are drawn as is";
    }
    world::WorldError err;
    const std::optional<world::World> w = smallSampleWorld(&err);
    ASSERT_TRUE(w.has_value()) << err.message;
    const csm_measure::WorldScene ws = csm_measure::sceneFromWorld(*w, true);
    size_t thinInstances = 0;
    for (const auto& inst : ws.scene.instances()) thinInstances += inst.thin ? 1 : 0;
    ASSERT_GT(thinInstances, 0u) << "the world has no thin cluster";
    harness->setScene(ws.scene);
    const csm_measure::RayTracer tracer(ws.scene);
    const world::AppSettings app;  // the fly-through's defaults
    const csm::DirectionalLight light{world::lightDirection(app)};
    const glm::dvec3 l = glm::normalize(light.directionWs);
    csm::ShadowSettings settings = world::effectiveShadow(app);

    // Points on the casters' centre lines, and where each casts its shadow on the terrain.
    std::vector<Sample> samples;
    glm::dvec3 lineMin(1e30), lineMax(-1e30), fenceMin(1e30), fenceMax(-1e30);
    auto addShadowOf = [&](const glm::dvec3& p, int cls) {
      glm::dvec3 hit;
      glm::vec3 n;
      // From just beyond the caster (3 cm cables, 6 cm rails) along the light.
      if (!tracer.intersect(p + l * 0.1, l, &hit, &n)) return;
      if (n.y < 0.0f) n = -n;
      if (n.y < 0.5f || std::abs(hit.y - w->heightAt(hit.x, hit.z)) > 0.3) return;  // not terrain
      samples.push_back({{hit, n, csm_measure::InstanceKind::kGround}, cls});
    };
    for (const world::Object& o : w->objects) {
      if (o.kind == world::Kind::kCable) {
        const glm::dvec3 d(o.linear[0]);  // the cable, from translationWs, full length
        const double len = glm::length(d);
        for (double t = 0.25; t < len - 0.25; t += 0.5)
          addShadowOf(o.translationWs + d * (t / len), 0);
        lineMin = glm::min(lineMin, o.boundsWs.minWs);
        lineMax = glm::max(lineMax, o.boundsWs.maxWs);
      } else if (o.kind == world::Kind::kFence) {
        // The two rails of a segment (world.cpp: x +-0.03, y 0.5-0.6 and 1.1-1.2, z 0-3).
        for (double y : {0.55, 1.15}) {
          for (double z = 0.25; z < 2.8; z += 0.25) {
            addShadowOf(
                o.translationWs + glm::dvec3(o.linear * glm::vec3(0.0f, float(y), float(z))), 1);
          }
        }
        fenceMin = glm::min(fenceMin, o.boundsWs.minWs);
        fenceMax = glm::max(fenceMax, o.boundsWs.maxWs);
      }
    }
    // Keep those the truth puts in shadow (the ray back to the light meets the caster).
    {
      std::vector<glm::dvec3> pos;
      std::vector<glm::vec3> nrm;
      for (const Sample& s : samples) {
        pos.push_back(s.receiver.posWs);
        nrm.push_back(s.receiver.normalWs);
      }
      std::vector<float> vis(pos.size());
      tracer.visibility(pos, nrm, light.directionWs, vis, 1e-3);
      std::vector<Sample> kept;
      for (size_t i = 0; i < samples.size(); ++i) {
        if (vis[i] < 0.5f) kept.push_back(samples[i]);
      }
      samples = std::move(kept);
    }
    ASSERT_GT(samples.size(), 1000u);

    // Two views: along the power line from its west end (its cables from 20 m to 1.5 km, every
    // cascade), and over the fields from their west side (fences 40-340 m away).
    const glm::dvec3 lineWest(lineMin.x - 30.0, 0.0, 0.5 * (lineMin.z + lineMax.z) + 40.0);
    const glm::dvec3 lineEye(lineWest.x, w->heightAt(lineWest.x, lineWest.z) + 25.0, lineWest.z);
    const glm::dvec3 lineLook(lineMax.x, w->heightAt(lineMax.x, lineMax.z - 20.0),
                              lineMax.z - 20.0);
    const glm::dvec3 fieldWest(fenceMin.x - 40.0, 0.0, 0.5 * (fenceMin.z + fenceMax.z));
    const glm::dvec3 fieldEye(fieldWest.x, w->heightAt(fieldWest.x, fieldWest.z) + 25.0,
                              fieldWest.z);
    const glm::dvec3 fieldLook(fenceMax.x, w->heightAt(fenceMax.x, fieldWest.z), fieldWest.z);
    const csm::Camera views[2] = {cameraAt(lineEye, lineLook), cameraAt(fieldEye, fieldLook)};

    // (view, class, cascade) -> lost / mean per widening.
    struct Cell {
      uint64_t n = 0, lost = 0;
      double sumS = 0.0, texelM = 0.0;
    };
    const float widens[] = {0.0f, 0.5f, 1.0f};
    for (csm::PcfKernel kernel : {csm::PcfKernel::kTent3, csm::PcfKernel::k1Tap}) {
      std::map<std::tuple<int, int>, Cell> cells[3];  // per widening: (class, cascade)
      for (int v = 0; v < 2; ++v) {
        // This view's receivers: in front of it, within its vertical field of view.
        const glm::dvec3 eye = views[v].positionWs;
        const glm::dvec3 fwd = glm::dvec3(views[v].orientationWs * glm::dvec3(0, 0, -1));
        std::vector<csm_measure::Receiver> receivers;
        std::vector<int> cls;
        for (const Sample& s : samples) {
          const glm::dvec3 d = s.receiver.posWs - eye;
          if (glm::dot(glm::normalize(d), fwd) < std::cos(glm::radians(28.0))) continue;
          receivers.push_back(s.receiver);
          cls.push_back(s.cls);
        }
        for (int k = 0; k < 3; ++k) {
          csm::vk::RendererOptions opt;
          opt.thinCasterWidenTexels = widens[k];
          CSM_ASSERT_STATUS(harness->configure(settings, opt));
          csm::CascadeHistory history;
          const csm::CascadeFrame frame = harness->computeFrame(views[v], light, history);
          const auto results = harness->probe(frame, receivers, kernel);
          for (size_t i = 0; i < results.size(); ++i) {
            const int c = results[i].cascade;
            if (c < 0) continue;
            Cell& cell = cells[k][{cls[i], c}];
            ++cell.n;
            cell.lost += results[i].shadow > 0.5f ? 1 : 0;
            cell.sumS += results[i].shadow;
            cell.texelM = frame.cascades[size_t(c)].texelSizeM();
          }
        }
      }
      for (const auto& [key, off] : cells[0]) {
        const auto [cl, c] = key;
        const Cell& half = cells[1][key];
        const Cell& one = cells[2][key];
        ASSERT_EQ(half.n, off.n);
        ASSERT_EQ(one.n, off.n);
        const double width = cl == 0 ? 0.03 : 0.06;
        auto frac = [](const Cell& x) { return double(x.lost) / double(x.n); };
        std::printf(
            "%-7s %-15s cascade %d (texel %6.3f m, %5.2f texels wide, %5llu receivers): lost "
            "%6.2f%% off, %6.2f%% widened 0.5, %6.2f%% widened 1; mean shadow %.3f / %.3f / "
            "%.3f\n",
            csm::kernelName(kernel), kClassNames[cl], c, off.texelM, width / off.texelM,
            (unsigned long long)off.n, 100.0 * frac(off), 100.0 * frac(half), 100.0 * frac(one),
            off.sumS / off.n, half.sumS / half.n, one.sumS / one.n);
        report["runs"].push_back({{"kernel", csm::kernelName(kernel)},
                                  {"caster", kClassNames[cl]},
                                  {"width_m", width},
                                  {"cascade", c},
                                  {"texel_m", off.texelM},
                                  {"width_texels", width / off.texelM},
                                  {"receivers", off.n},
                                  {"lost_fraction_off", frac(off)},
                                  {"lost_fraction_widened_0_5", frac(half)},
                                  {"lost_fraction_widened_1", frac(one)},
                                  {"mean_shadow_off", off.sumS / off.n},
                                  {"mean_shadow_widened_0_5", half.sumS / half.n},
                                  {"mean_shadow_widened_1", one.sumS / one.n}});
        if (off.n < 50) continue;
        // The widening only darkens the true shadow.
        EXPECT_LE(frac(half), frac(off) + 0.01) << kClassNames[cl] << " cascade " << c;
        EXPECT_LE(frac(one), frac(half) + 0.01) << kClassNames[cl] << " cascade " << c;
        EXPECT_LE(half.sumS, off.sumS + 1e-3 * off.n) << kClassNames[cl] << " cascade " << c;
        EXPECT_LE(one.sumS, half.sumS + 1e-3 * off.n) << kClassNames[cl] << " cascade " << c;
        // At one texel it brings back a good part of what was lost, under
        // either kernel, except where the normal offset (1.5 texels along the normal) lifts the
        // receiver above the caster: the fences' rails, 0.5-1.2 m above the ground, in cascade
        // 3's 1.8 m texels (peter-panning of a low caster, not a thin-caster loss).
        const bool aboveCaster = cl == 1 && 1.5 * off.texelM > 1.15;
        if (frac(off) > 0.5 && !aboveCaster) {
          EXPECT_LT(frac(one), frac(off) - 0.2) << kClassNames[cl] << " cascade " << c;
        }
      }
    }
  }
  EXPECT_EQ(engine::validationMessageCount(), 0u);
  report["what"] =
      "The sample world's 3 cm cables and 6 cm fence rails (its thin clusters flagged) at the "
      "fly-through's shadow settings and sun: per kernel, class and cascade, the fraction of "
      "receivers in their true shadow read shaded > 0.5 (lost) and the mean shadow factor, with "
      "the widening off, at 0.5 and at 1 texel (points on the centre line of the true shadow: the "
      "image-space measure is thin_image.json).";
  csm_measure::writeJson(artefactDir() + "/thin_world.json", report);
}

}  // namespace
}  // namespace csm_stability
