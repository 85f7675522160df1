// Thin casters as the image shows them: the power line's 3 cm cables, seen from the `cables`
// path at the fly-through's view (1280x720, 60 degrees) and shadow settings, against the
// ray-traced truth. Across each cable's shadow on the terrain a section of receivers one screen
// pixel apart (what adjacent pixels of the image sample); per pixel the module's shadow factor
// (csm.glsl at the pixel's centre, the fly-through's kernel) and the truth (Embree, the pixel's
// coverage: the mean visibility of 16 points across its width). Per section, in pixels:
//   darker = sum(1 - factor) - sum(1 - truth)      (the shadow's mass: width x darkness)
//   wider  = #(factor < 0.5) - #(truth < 0.5)       (the band that reads dark)
// A widened caster's shadow is never wider or darker than its true shadow by more than one
// pixel (issue 24). Sections where anything but the cables shades the truth are left out.
// Views: the cables path (start, middle, end), along the line from its west end, and across it
// from 450 m (asserted on all but the last; see below).
// Writes test_artefacts/stability/thin_image.json.
#include <sample_world/paths.hpp>
#include <sample_world/settings.hpp>
#include <sample_world/world.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include <csm_measure/world_scene.hpp>
#include <engine/camera.hpp>

#include "small_world.hpp"
#include "stability_common.hpp"

namespace csm_stability {
namespace {

struct Section {
  std::vector<csm_measure::Receiver> pixels;
  std::vector<float> truth;  // coverage-weighted visibility per pixel
  double distanceM = 0.0;
  double pixelM = 0.0;                  // metres per pixel along the section
  int half = 0;                         // pixels[half] is the middle cable's shadow centre
  double cablePx[3] = {0.0, 0.0, 0.0};  // the three cables' shadow centres (pixels from it)
};

struct Stats {
  uint64_t n = 0;
  double maxDarker = -1e9, maxWider = -1e9, sumDarker = 0.0, sumTruthMass = 0.0;
  double texelPx = 0.0;
  double sumMass2 = 0.0, sumMass = 0.0;  // the rendered mass's spread along the line
};

TEST(StabilityThinCasters, CableShadowsInTheImageNoWiderOrDarkerThanTruthByMoreThanAPixel) {
  nlohmann::json report;
  report["runs"] = nlohmann::json::array();
  {
    CSM_MAKE_HARNESS(harness);
    world::WorldError err;
    const std::optional<world::World> w = smallSampleWorld(&err);
    ASSERT_TRUE(w.has_value()) << err.message;
    const csm_measure::WorldScene ws = csm_measure::sceneFromWorld(*w, true);
    harness->setScene(ws.scene);
    const csm_measure::RayTracer tracer(ws.scene);
    // The cables alone: a section is kept only where the full scene's truth is theirs.
    csm_measure::Scene cablesOnly(ws.scene.originWs());
    uint32_t cableMesh = 0;
    bool haveMesh = false;
    std::vector<const world::Object*> cables;
    for (const world::Object& o : w->objects) {
      if (o.kind != world::Kind::kCable) continue;
      cables.push_back(&o);
      if (!haveMesh) {
        const world::MeshData& m = w->meshes[o.mesh].lods[0];
        csm_measure::MeshData md;
        md.name = "cable";
        for (size_t i = 0; i < m.positions.size(); ++i)
          md.vertices.push_back({m.positions[i], m.normals[i]});
        md.indices = m.indices;
        cableMesh = cablesOnly.addMesh(std::move(md));
        haveMesh = true;
      }
      cablesOnly.addInstance({cableMesh, o.translationWs, o.linear, glm::vec4(1.0f),
                              csm_measure::InstanceKind::kBuilding, false, false});
    }
    ASSERT_EQ(cables.size() % 3, 0u);
    ASSERT_GT(cables.size(), 30u);
    const csm_measure::RayTracer cableTracer(cablesOnly);

    const world::AppSettings app;  // the fly-through's defaults
    const csm::DirectionalLight light{world::lightDirection(app)};
    const glm::dvec3 l = glm::normalize(light.directionWs);
    const csm::ShadowSettings settings = world::effectiveShadow(app);
    csm::vk::RendererOptions opt;
    opt.thinCasterWidenTexels = app.thinCasters ? app.thinWidenTexels : 0.0f;
    const double widthPx = app.width, heightPx = app.height;
    const std::optional<world::FlightPath> path = world::FlightPath::make("cables", *w, app.fovDeg);
    ASSERT_TRUE(path.has_value());

    // The cables path at its start, middle and end (the line 130-210 m away, looking across it),
    // and (t = -1) along the line from beyond its west end, 25 m up: its cables 20 m to 1.5 km
    // away, every cascade.
    glm::dvec3 lineMin(1e30), lineMax(-1e30);
    for (const world::Object* o : cables) {
      lineMin = glm::min(lineMin, o->boundsWs.minWs);
      lineMax = glm::max(lineMax, o->boundsWs.maxWs);
    }
    for (double t : {0.0, 0.5, 1.0, -1.0, -2.0}) {
      engine::Camera ec;
      if (t >= 0.0) {
        ec = world::poseCamera(path->at(t), widthPx / heightPx, 0.5, app.farM);
      } else {
        const glm::dvec3 mid = 0.5 * (lineMin + lineMax);
        // -1: from beyond the west end along the line; -2: from 450 m south of its middle, 60 m
        // up, across it (the cables 450-700 m away).
        const glm::dvec3 at = t == -1.0 ? glm::dvec3(lineMin.x - 30.0, 0.0, mid.z + 25.0)
                                        : glm::dvec3(mid.x, 0.0, mid.z + 450.0);
        ec.positionWs = {at.x, w->heightAt(at.x, at.z) + (t == -1.0 ? 25.0 : 60.0), at.z};
        if (t == -1.0) {
          ec.lookAt({lineMax.x, w->heightAt(lineMax.x, lineMax.z - 20.0), lineMax.z - 20.0});
        } else {
          ec.lookAt({mid.x, w->heightAt(mid.x, mid.z), mid.z});
        }
        ec.fovYRad = glm::radians(app.fovDeg);
        ec.aspect = widthPx / heightPx;
        ec.nearM = 0.5;
        ec.farM = app.farM;
      }
      const csm::Camera cam = glue::toCsmCamera(ec);
      const glm::dquat q = cam.orientationWs;
      const double tanY = std::tan(0.5 * cam.fovYRad), tanX = tanY * cam.aspect;
      // Screen pixel of a world point (nothing behind the camera).
      auto toPixel = [&](const glm::dvec3& p, glm::dvec2* px) {
        const glm::dvec3 v = glm::conjugate(q) * (p - cam.positionWs);
        if (v.z > -0.1) return false;
        *px = {(v.x / (-v.z * tanX) * 0.5 + 0.5) * widthPx,
               (0.5 - v.y / (-v.z * tanY) * 0.5) * heightPx};
        return px->x >= 0 && px->y >= 0 && px->x < widthPx && px->y < heightPx;
      };
      // The terrain under (x, z): exact point and normal (false where something else is hit).
      auto terrainAt = [&](double x, double z, csm_measure::Receiver* r) {
        const glm::dvec3 top(x, w->heightAt(x, z) + 40.0, z);
        glm::dvec3 hit;
        glm::vec3 n;
        if (!tracer.intersect(top, {0.0, -1.0, 0.0}, &hit, &n)) return false;
        if (n.y < 0.0f) n = -n;
        if (std::abs(hit.y - w->heightAt(x, z)) > 0.3 || n.y < 0.5f) return false;
        *r = {hit, n, csm_measure::InstanceKind::kGround};
        return true;
      };
      auto shadowOf = [&](const glm::dvec3& p, glm::dvec3* hit) {
        glm::vec3 n;
        return tracer.intersect(p + l * 0.1, l, hit, &n) &&
               std::abs(hit->y - w->heightAt(hit->x, hit->z)) < 0.3;
      };
      std::vector<Section> sections;
      for (size_t s = 0; s + 2 < cables.size(); s += 3) {
        const world::Object& mid = *cables[s + 1];
        const glm::dvec3 d(mid.linear[0]);
        const double len = glm::length(d);
        const glm::dvec3 across = glm::normalize(glm::cross(glm::dvec3(0, 1, 0), d / len));
        for (double u = 2.0; u < len - 2.0; u += 3.0) {
          glm::dvec3 centre, outer[2];
          if (!shadowOf(mid.translationWs + d * (u / len), &centre)) continue;
          if (!shadowOf(cables[s]->translationWs + glm::dvec3(cables[s]->linear[0]) * (u / len),
                        &outer[0]) ||
              !shadowOf(
                  cables[s + 2]->translationWs + glm::dvec3(cables[s + 2]->linear[0]) * (u / len),
                  &outer[1])) {
            continue;
          }
          glm::dvec2 a, b;
          if (!toPixel(centre, &a) || !toPixel(centre + across * 0.05, &b)) continue;
          // Visible from the camera (nothing in front of the ground point).
          {
            glm::dvec3 hit;
            glm::vec3 n;
            const glm::dvec3 toC = centre - cam.positionWs;
            if (tracer.intersect(cam.positionWs, glm::normalize(toC), &hit, &n) &&
                glm::length(hit - cam.positionWs) < glm::length(toC) - 0.05) {
              continue;
            }
          }
          Section sec;
          sec.pixelM = 0.05 / std::max(glm::length(b - a), 1e-6);
          sec.distanceM = glm::length(centre - cam.positionWs);
          const double reach = std::max(std::abs(glm::dot(outer[0] - centre, across)),
                                        std::abs(glm::dot(outer[1] - centre, across)));
          // The cables' shadows and 4 m beyond (the widest kernel's reach at the far cascade).
          const int half = int(std::ceil((reach + 4.0) / sec.pixelM));
          if (half > 400) continue;
          sec.half = half;
          sec.cablePx[0] = glm::dot(outer[0] - centre, across) / sec.pixelM;
          sec.cablePx[2] = glm::dot(outer[1] - centre, across) / sec.pixelM;
          bool ok = true;
          std::vector<glm::dvec3> sub;
          std::vector<glm::vec3> subN;
          for (int k = -half; k <= half && ok; ++k) {
            const glm::dvec3 p = centre + across * (k * sec.pixelM);
            csm_measure::Receiver r;
            ok = terrainAt(p.x, p.z, &r);
            sec.pixels.push_back(r);
            for (int j = 0; j < 16 && ok; ++j) {
              const glm::dvec3 sp = centre + across * ((k + (j + 0.5) / 16.0 - 0.5) * sec.pixelM);
              csm_measure::Receiver sr;
              ok = terrainAt(sp.x, sp.z, &sr);
              sub.push_back(sr.posWs);
              subN.push_back(sr.normalWs);
            }
          }
          if (!ok) continue;
          std::vector<float> vis(sub.size()), visCables(sub.size());
          tracer.visibility(sub, subN, light.directionWs, vis, 1e-3);
          cableTracer.visibility(sub, subN, light.directionWs, visCables, 1e-3);
          if (vis != visCables) continue;  // something else shades the section
          for (size_t k = 0; k < sec.pixels.size(); ++k) {
            double m = 0.0;
            for (int j = 0; j < 16; ++j) m += vis[k * 16 + size_t(j)];
            sec.truth.push_back(float(m / 16.0));
          }
          sections.push_back(std::move(sec));
        }
      }
      ASSERT_GT(sections.size(), 20u) << "t = " << t;
      double nearest = 1e30, farthest = 0.0;
      for (const Section& sec : sections) {
        nearest = std::min(nearest, sec.distanceM);
        farthest = std::max(farthest, sec.distanceM);
      }
      std::printf("view %4.1f: %zu sections across the cables' shadows, %.0f-%.0f m away\n", t,
                  sections.size(), nearest, farthest);

      std::vector<csm_measure::Receiver> receivers;
      for (const Section& sec : sections)
        receivers.insert(receivers.end(), sec.pixels.begin(), sec.pixels.end());
      const float widens[] = {0.0f, app.thinWidenTexels, 0.25f, 0.5f, 1.0f};
      double variation[2] = {0.0, 0.0};  // W = 0 and the fly-through's, the worst cascade
      for (int wi = 0; wi < 5; ++wi) {
        const float widen = widens[wi];
        if (wi > 1 && widen == app.thinWidenTexels) continue;
        opt.thinCasterWidenTexels = widen;
        CSM_ASSERT_STATUS(harness->configure(settings, opt));
        csm::CascadeHistory history;
        const csm::CascadeFrame frame = harness->computeFrame(cam, light, history);
        const auto results = harness->probe(frame, receivers, app.shadow.kernel);
        std::map<int, Stats> perCascade;
        size_t at = 0;
        for (const Section& sec : sections) {
          // Each pixel counts for the cable whose shadow centre is nearest.
          double mass[3] = {0, 0, 0}, truthMass[3] = {0, 0, 0};
          int dark[3] = {0, 0, 0}, truthDark[3] = {0, 0, 0};
          const int cascade = results[at + size_t(sec.half)].cascade;
          for (size_t k = 0; k < sec.pixels.size(); ++k, ++at) {
            const double x = double(k) - sec.half;
            int near = 0;
            for (int c = 1; c < 3; ++c) {
              if (std::abs(x - sec.cablePx[c]) < std::abs(x - sec.cablePx[near])) near = c;
            }
            const double f = results[at].shadow;  // the factor (1 = lit)
            mass[near] += 1.0 - f;
            truthMass[near] += 1.0 - sec.truth[k];
            dark[near] += f < 0.5 ? 1 : 0;
            truthDark[near] += sec.truth[k] < 0.5f ? 1 : 0;
          }
          if (cascade < 0) continue;
          Stats& st = perCascade[cascade];
          for (int c = 0; c < 3; ++c) {
            const double darker = mass[c] - truthMass[c];
            const int wider = dark[c] - truthDark[c];
            ++st.n;
            st.maxDarker = std::max(st.maxDarker, darker);
            st.maxWider = std::max(st.maxWider, double(wider));
            st.sumDarker += darker;
            st.sumTruthMass += truthMass[c];
            st.sumMass += mass[c];
            st.sumMass2 += mass[c] * mass[c];
            // The fly-through's widening: within a pixel of the truth. Not asserted from 450 m
            // (view -2, the last cascade, texels of about 2.4 px): there one texel's shadow is
            // already more than a pixel darker than a 3 cm cable's, at any widening including
            // none (measured, thin_casters.md); meeting it there needs thin casters left out of
            // cascades whose texels exceed the view's pixels, which the module does not do.
            if (wi == 1 && t != -2.0) {
              EXPECT_LE(darker, 1.0) << "view " << t << ", cascade " << cascade << ", cable " << c
                                     << ", " << sec.distanceM << " m away";
              EXPECT_LE(wider, 1) << "view " << t << ", cascade " << cascade << ", cable " << c
                                  << ", " << sec.distanceM << " m away";
            }
          }
          st.texelPx =
              std::max(st.texelPx, frame.cascades[size_t(cascade)].texelSizeM() / sec.pixelM);
        }
        for (const auto& [c, st] : perCascade) {
          const double mean = st.sumMass / st.n;
          const double cv =
              std::sqrt(std::max(0.0, st.sumMass2 / st.n - mean * mean)) / std::max(mean, 1e-9);
          std::printf(
              "view %4.1f widen %.3f cascade %d: %4llu cable sections, texel up to %.2f px; "
              "darker than truth by %.2f px at most (mean %.2f; truth %.2f px), wider by %.0f px "
              "at most; mass varies %.0f%% along the line\n",
              t, widen, c, (unsigned long long)st.n, st.texelPx, st.maxDarker, st.sumDarker / st.n,
              st.sumTruthMass / st.n, st.maxWider, 100.0 * cv);
          report["runs"].push_back({{"view", t},
                                    {"widen_texels", widen},
                                    {"cascade", c},
                                    {"cable_sections", st.n},
                                    {"texel_px_max", st.texelPx},
                                    {"darker_px_max", st.maxDarker},
                                    {"darker_px_mean", st.sumDarker / st.n},
                                    {"truth_mass_px_mean", st.sumTruthMass / st.n},
                                    {"wider_px_max", st.maxWider},
                                    {"mass_variation", cv},
                                    {"criterion_asserted", t != -2.0}});
          if (st.n < 60) continue;
          if (wi == 0) {
            // Unwidened, rasterisation keeps the true width on average: the measurement is fair.
            EXPECT_NEAR(st.sumDarker / st.n, 0.0, 0.1) << "view " << t << ", cascade " << c;
          }
          if (wi < 2) variation[wi] = std::max(variation[wi], cv);
        }
      }
      // The widening is what keeps the line whole: it varies less along the line.
      if (app.thinWidenTexels > 0.0f) {
        EXPECT_LT(variation[1], 0.75 * variation[0]) << "view " << t;
      }
    }
  }
  EXPECT_EQ(engine::validationMessageCount(), 0u);
  report["what"] =
      "The power line's 3 cm cables from the cables path (t = 0, 0.5, 1) at the fly-through's "
      "view, shadow settings and kernel: per section across a cable's shadow, pixels one screen "
      "pixel apart, how much darker (sum of 1 - factor) and wider (pixels below 0.5) than the "
      "ray-traced truth (each pixel's coverage), in pixels.";
  csm_measure::writeJson(artefactDir() + "/thin_image.json", report);
}

}  // namespace
}  // namespace csm_stability
