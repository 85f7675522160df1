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

// The small sample world and its scene with the thin clusters flagged as the fly-through flags
// them, made once for this file's tests (`error` says why not).
struct ThinWorld {
  world::World world;
  csm_measure::WorldScene scene;
  std::string error;
};
const ThinWorld* thinWorld() {
  static const ThinWorld made = [] {
    ThinWorld t;
    world::WorldError err;
    std::optional<world::World> w = smallSampleWorld(&err);
    if (!w) {
      t.error = err.message.empty() ? "no world" : err.message;
      return t;
    }
    t.world = std::move(*w);
    t.scene = csm_measure::sceneFromWorld(t.world, true);
    return t;
  }();
  return &made;
}

// What the image sees of a camera: a world point's screen pixel, and whether it is in view.
struct ScreenView {
  csm::Camera cam;
  double widthPx = 0.0, heightPx = 0.0;

  // Screen pixel of a world point (nothing behind the camera).
  bool toPixel(const glm::dvec3& p, glm::dvec2* px) const {
    const double tanY = std::tan(0.5 * cam.fovYRad), tanX = tanY * cam.aspect;
    const glm::dvec3 v = glm::conjugate(cam.orientationWs) * (p - cam.positionWs);
    if (v.z > -0.1) return false;
    *px = {(v.x / (-v.z * tanX) * 0.5 + 0.5) * widthPx,
           (0.5 - v.y / (-v.z * tanY) * 0.5) * heightPx};
    return px->x >= 0 && px->y >= 0 && px->x < widthPx && px->y < heightPx;
  }
  // Nothing in front of the point `p` seen from the camera.
  bool visible(const csm_measure::RayTracer& tracer, const glm::dvec3& p) const {
    glm::dvec3 hit;
    glm::vec3 n;
    const glm::dvec3 to = p - cam.positionWs;
    return !(tracer.intersect(cam.positionWs, glm::normalize(to), &hit, &n) &&
             glm::length(hit - cam.positionWs) < glm::length(to) - 0.05);
  }
};

// The terrain of `w` under (x, z): exact point and normal (false where something else is hit).
bool terrainAt(const world::World& w, const csm_measure::RayTracer& tracer, double x, double z,
               csm_measure::Receiver* r) {
  const glm::dvec3 top(x, w.heightAt(x, z) + 40.0, z);
  glm::dvec3 hit;
  glm::vec3 n;
  if (!tracer.intersect(top, {0.0, -1.0, 0.0}, &hit, &n)) return false;
  if (n.y < 0.0f) n = -n;
  if (std::abs(hit.y - w.heightAt(x, z)) > 0.3 || n.y < 0.5f) return false;
  *r = {hit, n, csm_measure::InstanceKind::kGround};
  return true;
}

// A section of `half` pixels each side of `centre` along `across` (one screen pixel apart,
// `sec->pixelM`) on the terrain: its receivers, and each pixel's truth (the mean visibility of 16
// points across it). False where the section leaves the terrain or where anything the
// `onlyTracer` scene lacks shades it (the full scene's truth differs from that scene's).
bool traceSection(const world::World& w, const csm_measure::RayTracer& tracer,
                  const csm_measure::RayTracer& onlyTracer, const glm::dvec3& lightDirWs,
                  const glm::dvec3& centre, const glm::dvec3& across, Section* sec) {
  std::vector<glm::dvec3> sub;
  std::vector<glm::vec3> subN;
  for (int k = -sec->half; k <= sec->half; ++k) {
    const glm::dvec3 p = centre + across * (k * sec->pixelM);
    csm_measure::Receiver r;
    if (!terrainAt(w, tracer, p.x, p.z, &r)) return false;
    sec->pixels.push_back(r);
    for (int j = 0; j < 16; ++j) {
      const glm::dvec3 sp = centre + across * ((k + (j + 0.5) / 16.0 - 0.5) * sec->pixelM);
      csm_measure::Receiver sr;
      if (!terrainAt(w, tracer, sp.x, sp.z, &sr)) return false;
      sub.push_back(sr.posWs);
      subN.push_back(sr.normalWs);
    }
  }
  std::vector<float> vis(sub.size()), visOnly(sub.size());
  tracer.visibility(sub, subN, lightDirWs, vis, 1e-3);
  onlyTracer.visibility(sub, subN, lightDirWs, visOnly, 1e-3);
  if (vis != visOnly) return false;
  for (size_t k = 0; k < sec->pixels.size(); ++k) {
    double m = 0.0;
    for (int j = 0; j < 16; ++j) m += vis[k * 16 + size_t(j)];
    sec->truth.push_back(float(m / 16.0));
  }
  return true;
}

// The objects of `kind` as a scene of their own (the truth of what they alone shade).
csm_measure::Scene kindOnlyScene(const world::World& w, const csm_measure::Scene& full,
                                 world::Kind kind, std::vector<const world::Object*>* objects) {
  csm_measure::Scene only(full.originWs());
  std::map<uint32_t, uint32_t> meshOf;
  for (const world::Object& o : w.objects) {
    if (o.kind != kind) continue;
    objects->push_back(&o);
    auto it = meshOf.find(o.mesh);
    if (it == meshOf.end()) {
      const world::MeshData& m = w.meshes[o.mesh].lods[0];
      csm_measure::MeshData md;
      md.name = world::kindName(kind);
      for (size_t i = 0; i < m.positions.size(); ++i)
        md.vertices.push_back({m.positions[i], m.normals[i]});
      md.indices = m.indices;
      it = meshOf.emplace(o.mesh, only.addMesh(std::move(md))).first;
    }
    only.addInstance({it->second, o.translationWs, o.linear, glm::vec4(1.0f),
                      csm_measure::InstanceKind::kBuilding, false, false});
  }
  return only;
}

// The views of the power line: the cables path at t in [0, 1] (the line 130-210 m away, looking
// across it); t = -1 along the line from beyond its west end, 25 m up (its cables 20 m to 1.5 km
// away, every cascade); t = -2 from 450 m south of its middle, 60 m up (450-720 m away, the last
// cascade); t = -3 from 280 m south of its middle, 40 m up (its poles 280-400 m away).
engine::Camera lineView(const world::World& w, const world::AppSettings& app,
                        const world::FlightPath& path, double t, const glm::dvec3& lineMin,
                        const glm::dvec3& lineMax) {
  const double aspect = double(app.width) / double(app.height);
  if (t >= 0.0) return world::poseCamera(path.at(t), aspect, 0.5, app.farM);
  engine::Camera ec;
  const glm::dvec3 mid = 0.5 * (lineMin + lineMax);
  const double south = t == -2.0 ? 450.0 : 280.0;
  // t = -3 - k, k in [0, 4]: 280 m south of the line at 300 m steps along it (k = 2: its middle).
  const double shift = t <= -3.0 ? (-3.0 - t - 2.0) * 300.0 : 0.0;
  const glm::dvec3 at = t == -1.0 ? glm::dvec3(lineMin.x - 30.0, 0.0, mid.z + 25.0)
                                  : glm::dvec3(mid.x + shift, 0.0, mid.z + south);
  const double up = t == -1.0 ? 25.0 : t == -2.0 ? 60.0 : 40.0;
  ec.positionWs = {at.x, w.heightAt(at.x, at.z) + up, at.z};
  if (t == -1.0) {
    ec.lookAt({lineMax.x, w.heightAt(lineMax.x, lineMax.z - 20.0), lineMax.z - 20.0});
  } else {
    ec.lookAt({at.x, w.heightAt(at.x, mid.z), mid.z});
  }
  ec.fovYRad = glm::radians(app.fovDeg);
  ec.aspect = aspect;
  ec.nearM = 0.5;
  ec.farM = app.farM;
  return ec;
}

TEST(StabilityThinCasters, CableShadowsInTheImageNoWiderOrDarkerThanTruthByMoreThanAPixel) {
  nlohmann::json report;
  report["runs"] = nlohmann::json::array();
  {
    CSM_MAKE_HARNESS(harness);
    const ThinWorld& made = *thinWorld();
    ASSERT_TRUE(made.error.empty()) << made.error;
    const world::World* w = &made.world;
    const csm_measure::WorldScene& ws = made.scene;
    harness->setScene(ws.scene);
    const csm_measure::RayTracer tracer(ws.scene);
    // The cables alone: a section is kept only where the full scene's truth is theirs.
    std::vector<const world::Object*> cables;
    const csm_measure::Scene cablesOnly = kindOnlyScene(*w, ws.scene, world::Kind::kCable, &cables);
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

    // The cables path at its start, middle and end, along the line, and across it from 450 m
    // (lineView).
    glm::dvec3 lineMin(1e30), lineMax(-1e30);
    for (const world::Object* o : cables) {
      lineMin = glm::min(lineMin, o->boundsWs.minWs);
      lineMax = glm::max(lineMax, o->boundsWs.maxWs);
    }
    for (double t : {0.0, 0.5, 1.0, -1.0, -2.0}) {
      const engine::Camera ec = lineView(*w, app, *path, t, lineMin, lineMax);
      const csm::Camera cam = glue::toCsmCamera(ec);
      const ScreenView view{cam, widthPx, heightPx};
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
          if (!view.toPixel(centre, &a) || !view.toPixel(centre + across * 0.05, &b)) continue;
          if (!view.visible(tracer, centre)) continue;
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
          if (!traceSection(*w, tracer, cableTracer, light.directionWs, centre, across, &sec)) {
            continue;
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

// The power line's poles (0.28-0.36 m cones, CasterInstance::thinWidthM 0.28) as the image shows
// them. In a cascade whose texels are up to twice their width (the third: 0.46 m) a pole's band
// in the map covers texel centres along only part of its length where it runs nearly along a
// texel axis (it depends on the sun's azimuth), so its shadow breaks; the depth pass widens it
// there to one texel (csm::thinCasterWidenTexels). Sections across each pole's shadow on the
// terrain, one screen pixel apart, against the ray-traced truth as for the cables; a gap is a
// section whose rendered shadow mass is under half the truth's. Sun azimuths 140 (the default),
// 60, 90 and 110 degrees; views of the line from 280 m south (its poles 250-430 m away, the third
// cascade) and, at the default sun, from the cables path (the second) and 450 m (the last).
// Asserted with the world's widths where the rule acts (texel in (w, 2w]): no gap; no section
// more than a pixel wider than the truth (pixels below 0.5); per view, the shadow no more than a
// pixel darker than the truth on average. Elsewhere the factors are the same bit for bit. With the
// width unknown (the module before widths) the same sections have gaps: the measure can fail.
// Writes test_artefacts/stability/thin_poles.json.
TEST(StabilityThinCasters, PoleShadowsAreContinuousWhereATexelIsAtMostTwiceTheirWidth) {
  nlohmann::json report;
  report["runs"] = nlohmann::json::array();
  {
    CSM_MAKE_HARNESS(harness);
    const ThinWorld& made = *thinWorld();
    ASSERT_TRUE(made.error.empty()) << made.error;
    const world::World* w = &made.world;
    const csm_measure::WorldScene& ws = made.scene;
    // The same world with every thin width unknown (0).
    world::World unknown = *w;
    for (world::CasterCluster& c : unknown.clusters) c.thinWidthM = 0.0f;
    const csm_measure::WorldScene wsUnknown = csm_measure::sceneFromWorld(unknown, true);
    float poleWidthM = 0.0f;
    for (const world::CasterCluster& c : w->clusters) {
      if (c.name.rfind("thin poles", 0) == 0) poleWidthM = c.thinWidthM;
    }
    ASSERT_EQ(poleWidthM, 0.28f);
    const csm_measure::RayTracer tracer(ws.scene);
    std::vector<const world::Object*> poles, cables;
    const csm_measure::Scene polesOnly = kindOnlyScene(*w, ws.scene, world::Kind::kPole, &poles);
    (void)kindOnlyScene(*w, ws.scene, world::Kind::kCable, &cables);
    ASSERT_GT(poles.size(), 20u);
    const csm_measure::RayTracer poleTracer(polesOnly);
    glm::dvec3 lineMin(1e30), lineMax(-1e30);
    for (const world::Object* o : cables) {
      lineMin = glm::min(lineMin, o->boundsWs.minWs);
      lineMax = glm::max(lineMax, o->boundsWs.maxWs);
    }
    const world::AppSettings defaults;  // the fly-through's
    ASSERT_TRUE(defaults.thinCasters);
    uint64_t bandSections = 0, bandGapsUnknown = 0;
    int sceneKnown = 1;
    harness->setScene(ws.scene);
    for (double azimuth : {defaults.lightAzimuthDeg, 60.0, 90.0, 110.0}) {
      world::AppSettings app = defaults;
      app.lightAzimuthDeg = azimuth;
      const bool isDefault = azimuth == defaults.lightAzimuthDeg;
      const csm::DirectionalLight light{world::lightDirection(app)};
      const glm::dvec3 l = glm::normalize(light.directionWs);
      const csm::ShadowSettings settings = world::effectiveShadow(app);
      csm::vk::RendererOptions opt;
      opt.thinCasterWidenTexels = app.thinWidenTexels;
      const std::optional<world::FlightPath> path =
          world::FlightPath::make("cables", *w, app.fovDeg);
      ASSERT_TRUE(path.has_value());
      // Across a pole's shadow on the ground: its shadow runs along the light's horizontal part.
      const glm::dvec3 along = glm::normalize(glm::dvec3(l.x, 0.0, l.z));
      const glm::dvec3 across = glm::normalize(glm::cross(glm::dvec3(0, 1, 0), along));
      std::vector<double> views = {-3.0, -5.0, -7.0};
      if (isDefault) views.insert(views.end(), {0.0, 0.5, 1.0, -2.0});
      for (double t : views) {
        const engine::Camera ec = lineView(*w, app, *path, t, lineMin, lineMax);
        const csm::Camera cam = glue::toCsmCamera(ec);
        const ScreenView view{cam, double(app.width), double(app.height)};
        std::vector<Section> sections;
        for (const world::Object* pole : poles) {
          // The pole's axis from 1 m to 9.5 m up (below the cross arm and the cables).
          for (double h = 1.0; h <= 9.5; h += 0.5) {
            const glm::dvec3 p = pole->translationWs + glm::dvec3(0.0, h, 0.0);
            glm::dvec3 centre;
            glm::vec3 n;
            // From outside the cone (radius 0.18 m at most) along the light to the ground.
            if (!tracer.intersect(p + l * 0.5, l, &centre, &n) ||
                std::abs(centre.y - w->heightAt(centre.x, centre.z)) > 0.3) {
              continue;
            }
            glm::dvec2 a, b;
            if (!view.toPixel(centre, &a) || !view.toPixel(centre + across * 0.05, &b)) continue;
            if (!view.visible(tracer, centre)) continue;
            Section sec;
            sec.pixelM = 0.05 / std::max(glm::length(b - a), 1e-6);
            sec.distanceM = glm::length(centre - cam.positionWs);
            // The pole's shadow and 4 m each side (the widest kernel's reach at the far cascade).
            sec.half = int(std::ceil((0.2 + 4.0) / sec.pixelM));
            if (sec.half > 400) continue;
            if (traceSection(*w, tracer, poleTracer, light.directionWs, centre, across, &sec)) {
              sections.push_back(std::move(sec));
            }
          }
        }
        ASSERT_GT(sections.size(), 5u) << "azimuth " << azimuth << ", view " << t;
        std::vector<csm_measure::Receiver> receivers;
        for (const Section& sec : sections)
          receivers.insert(receivers.end(), sec.pixels.begin(), sec.pixels.end());
        std::vector<csm_measure::ProbeResult> results[2];  // width unknown, known
        csm::CascadeFrame frame;
        for (int k = 0; k < 2; ++k) {
          // Whichever scene the harness holds first: one upload per view.
          const int known = k == 0 ? sceneKnown : 1 - sceneKnown;
          if (known != sceneKnown) harness->setScene(known ? ws.scene : wsUnknown.scene);
          sceneKnown = known;
          CSM_ASSERT_STATUS(harness->configure(settings, opt));
          csm::CascadeHistory history;
          frame = harness->computeFrame(cam, light, history);
          results[known] = harness->probe(frame, receivers, app.shadow.kernel);
        }
        struct PoleStats {
          uint64_t n = 0, gaps[2] = {0, 0};
          double maxDarker[2] = {-1e9, -1e9}, sumDarker[2] = {0.0, 0.0}, sumTruthMass = 0.0;
          double maxAdded = -1e9, texelPx = 0.0, nearestM = 1e30, farthestM = 0.0;
          uint64_t inBand = 0;
          double sumDarkerInBand = 0.0;
          int maxWider[2] = {-1000, -1000};
        };
        std::map<int, PoleStats> perCascade;
        size_t at = 0;
        for (const Section& sec : sections) {
          double mass[2] = {0.0, 0.0}, truthMass = 0.0;
          int dark[2] = {0, 0}, truthDark = 0;
          bool same = true;
          const int cascade = results[1][at + size_t(sec.half)].cascade;
          for (size_t k = 0; k < sec.pixels.size(); ++k, ++at) {
            for (int known = 0; known < 2; ++known) {
              const double f = results[known][at].shadow;
              mass[known] += 1.0 - f;
              dark[known] += f < 0.5 ? 1 : 0;
            }
            same = same && results[0][at].shadow == results[1][at].shadow;
            truthMass += 1.0 - sec.truth[k];
            truthDark += sec.truth[k] < 0.5f ? 1 : 0;
          }
          if (cascade < 0) continue;
          const double texelM = frame.cascades[size_t(cascade)].texelSizeM();
          // Where the rule acts: a texel wider than the poles, at most twice as wide.
          const bool inBand = texelM > double(poleWidthM) && texelM <= 2.0 * double(poleWidthM);
          PoleStats& st = perCascade[cascade];
          ++st.n;
          for (int known = 0; known < 2; ++known) {
            st.gaps[known] += mass[known] < 0.5 * truthMass ? 1 : 0;
            st.maxDarker[known] = std::max(st.maxDarker[known], mass[known] - truthMass);
            st.sumDarker[known] += mass[known] - truthMass;
            st.maxWider[known] = std::max(st.maxWider[known], dark[known] - truthDark);
          }
          st.sumTruthMass += truthMass;
          st.maxAdded = std::max(st.maxAdded, mass[1] - mass[0]);
          st.texelPx = std::max(st.texelPx, texelM / sec.pixelM);
          st.nearestM = std::min(st.nearestM, sec.distanceM);
          st.farthestM = std::max(st.farthestM, sec.distanceM);
          const std::string where = "azimuth " + std::to_string(azimuth) + ", view " +
                                    std::to_string(t) + ", cascade " + std::to_string(cascade) +
                                    ", " + std::to_string(sec.distanceM) + " m away";
          if (inBand) {
            ++bandSections;
            bandGapsUnknown += mass[0] < 0.5 * truthMass ? 1 : 0;
            EXPECT_GE(mass[1], 0.5 * truthMass) << "a gap: " << where;
            EXPECT_LE(dark[1] - truthDark, 1) << where;
            ++st.inBand;
            st.sumDarkerInBand += mass[1] - truthMass;
          } else {
            EXPECT_TRUE(same) << "the rule acts outside its band: " << where;
          }
        }
        for (const auto& [c, st] : perCascade) {
          const double n = double(st.n);
          // On average over the view's sections the widened pole is within a pixel of the truth
          // (a section's own excess varies by up to 2 px with or without the widening: where the
          // terrain stretches a texel's shadow across several pixels).
          if (st.inBand > 0) {
            EXPECT_LE(st.sumDarkerInBand / double(st.inBand), 1.0)
                << "azimuth " << azimuth << ", view " << t << ", cascade " << c;
          }
          std::printf(
              "azimuth %5.1f view %4.1f cascade %d: %4llu pole sections %.0f-%.0f m away, texel "
              "up to %.2f px; gaps %llu -> %llu; darker than truth by at most %.2f -> %.2f px "
              "(mean %.2f -> %.2f; truth %.2f px), wider by at most %d -> %d px; the widening "
              "adds at most %.2f px (width unknown -> known)\n",
              azimuth, t, c, (unsigned long long)st.n, st.nearestM, st.farthestM, st.texelPx,
              (unsigned long long)st.gaps[0], (unsigned long long)st.gaps[1], st.maxDarker[0],
              st.maxDarker[1], st.sumDarker[0] / n, st.sumDarker[1] / n, st.sumTruthMass / n,
              st.maxWider[0], st.maxWider[1], st.maxAdded);
          report["runs"].push_back({{"azimuth_deg", azimuth},
                                    {"view", t},
                                    {"cascade", c},
                                    {"pole_sections", st.n},
                                    {"distance_m", {st.nearestM, st.farthestM}},
                                    {"texel_px_max", st.texelPx},
                                    {"gaps_width_unknown", st.gaps[0]},
                                    {"gaps", st.gaps[1]},
                                    {"darker_px_max_width_unknown", st.maxDarker[0]},
                                    {"darker_px_max", st.maxDarker[1]},
                                    {"darker_px_mean_width_unknown", st.sumDarker[0] / n},
                                    {"darker_px_mean", st.sumDarker[1] / n},
                                    {"truth_mass_px_mean", st.sumTruthMass / n},
                                    {"wider_px_max_width_unknown", st.maxWider[0]},
                                    {"wider_px_max", st.maxWider[1]},
                                    {"widening_adds_px_max", st.maxAdded}});
        }
      }
    }
    // Unknown widths leave gaps where the rule acts: what it fixes (the measure can fail).
    std::printf("texel in (w, 2w]: %llu sections, %llu gaps with the width unknown, 0 known\n",
                (unsigned long long)bandSections, (unsigned long long)bandGapsUnknown);
    EXPECT_GT(bandSections, 400u);
    EXPECT_GT(bandGapsUnknown, bandSections / 50);
    report["band_sections"] = bandSections;
    report["band_gaps_width_unknown"] = bandGapsUnknown;
  }
  EXPECT_EQ(engine::validationMessageCount(), 0u);
  report["what"] =
      "The power line's poles (0.28-0.36 m; thinWidthM 0.28) at sun azimuths 140 (default), 60, "
      "90, 110 degrees, from 280 m south of the line at three places, and at the default sun from "
      "the cables path and from 450 m, at the fly-through's view, shadow settings and kernel: per "
      "section across a pole's shadow, pixels one screen pixel apart, gaps (rendered mass under "
      "half the truth's), how much darker (sum of 1 - factor) and wider (pixels below 0.5) than "
      "the ray-traced truth, with the width unknown and known.";
  csm_measure::writeJson(artefactDir() + "/thin_poles.json", report);
}

}  // namespace
}  // namespace csm_stability
