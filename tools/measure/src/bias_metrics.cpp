// Acne and leak metrics against Embree shadow rays (see bias_metrics.hpp).
#include "csm_measure/bias_metrics.hpp"

#include <csm/selection.hpp>

#include <algorithm>
#include <cmath>

namespace csm_measure {
namespace {

constexpr int kDirections = 8;
constexpr int kDiskPoints = 64;

bool finitePixel(const PixelSample& p) {
  return std::isfinite(p.posWs.x) && std::isfinite(p.posWs.y) && std::isfinite(p.posWs.z) &&
         std::isfinite(p.normalWs.x) && std::isfinite(p.normalWs.y) && std::isfinite(p.normalWs.z);
}

// Two unit vectors orthogonal to unit `n` (and to each other).
void basis(const glm::dvec3& n, glm::dvec3& u, glm::dvec3& v) {
  const glm::dvec3 a = std::abs(n.y) < 0.9 ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0);
  u = glm::normalize(glm::cross(a, n));
  v = glm::cross(n, u);
}

// The larger texel of the pixel's cascade and of the cascade blended in (metres).
double pixelTexel(const PixelSample& p, const csm::CascadeFrame& frame) {
  double t = frame.cascades[size_t(p.cascade)].texelSizeM();
  if (p.blendCascade >= 0 && p.blendCascade < int(frame.cascadeCount) && p.blendWeight > 0.0f) {
    t = std::max(t, frame.cascades[size_t(p.blendCascade)].texelSizeM());
  }
  return t;
}

// The normal of the triangle under the pixel (Embree's geometric normal, turned to the side of
// the pixel's shading normal `n`), or `n` where no triangle is found within reach. On a coarse
// curved mesh the interpolated normal can be tilted tens of degrees from the facet: its tangent
// plane cuts into the mesh, whereas the facet's plane is a supporting plane of a convex mesh.
glm::dvec3 facetNormal(const RayTracer& tracer, const glm::dvec3& posWs, const glm::dvec3& n,
                       double reachM) {
  glm::dvec3 hit;
  glm::vec3 ng;
  if (!tracer.intersect(posWs + reachM * n, -n, &hit, &ng) ||
      glm::length(hit - posWs) > 2.0 * reachM || !std::isfinite(ng.x)) {
    return n;
  }
  const glm::dvec3 g = glm::normalize(glm::dvec3(ng));
  return glm::dot(g, n) < 0.0 ? -g : g;
}

// Marks lit facing pixels (idx[k], vis[k] >= 0.5) near an occluder instance (any kind but the
// ground): its bounds, projected across the light (basis lu, lv), come within edgeRadiusTexels of
// the pixel and some corner lies in front of the pixel's plane, toward the light.
void markNearOccluders(std::span<const PixelSample> pixels, const std::vector<size_t>& idx,
                       const std::vector<float>& vis, const csm::CascadeFrame& frame,
                       const Scene& scene, const glm::dvec3& toLight, const glm::dvec3& lu,
                       const glm::dvec3& lv, const BiasTruthDesc& desc,
                       std::vector<uint8_t>& nearEdge) {
  struct Box2 {
    glm::dvec2 lo, hi;
    glm::dvec3 corners[8];
  };
  std::vector<Box2> boxes;
  for (size_t i = 0; i < scene.instances().size(); ++i) {
    if (scene.instances()[i].kind == InstanceKind::kGround) continue;
    const csm::AabbWs& b = scene.instanceBounds(i);
    Box2 box{glm::dvec2(1e300), glm::dvec2(-1e300), {}};
    for (int c = 0; c < 8; ++c) {
      const glm::dvec3 p((c & 1) ? b.maxWs.x : b.minWs.x, (c & 2) ? b.maxWs.y : b.minWs.y,
                         (c & 4) ? b.maxWs.z : b.minWs.z);
      box.corners[c] = p;
      const glm::dvec2 q(glm::dot(p, lu), glm::dot(p, lv));
      box.lo = glm::min(box.lo, q);
      box.hi = glm::max(box.hi, q);
    }
    boxes.push_back(box);
  }
  for (size_t k = 0; k < idx.size(); ++k) {
    if (nearEdge[k] || vis[k] < 0.5f) continue;
    const PixelSample& p = pixels[idx[k]];
    const glm::dvec3 n = glm::normalize(glm::dvec3(p.normalWs));
    if (!(glm::dot(n, toLight) > desc.minFacing)) continue;
    const double r =
        desc.edgeRadiusTexels * pixelTexel(p, frame) + desc.footprintRadii * p.footprintM;
    const glm::dvec2 q(glm::dot(p.posWs, lu), glm::dot(p.posWs, lv));
    for (const Box2& box : boxes) {
      const glm::dvec2 d = glm::max(glm::max(box.lo - q, q - box.hi), glm::dvec2(0.0));
      if (glm::dot(d, d) > r * r) continue;
      bool inFront = false;
      for (const glm::dvec3& c : box.corners) inFront = inFront || glm::dot(c - p.posWs, n) > 0.01;
      if (inFront) {
        nearEdge[k] = 1;
        break;
      }
    }
  }
}

// Marks lit facing pixels whose surface meets other geometry or ends within the kernel's reach:
// rays along the surface in 8 directions, each long enough to cover edgeRadiusTexels across the
// light, and from each ray's end back onto the surface.
void markSurfaceFeatures(std::span<const PixelSample> pixels, const std::vector<size_t>& idx,
                         const std::vector<float>& vis, const csm::CascadeFrame& frame,
                         const RayTracer& tracer, const glm::dvec3& toLight,
                         const BiasTruthDesc& desc, std::vector<uint8_t>& nearEdge) {
  for (size_t k = 0; k < idx.size(); ++k) {
    if (nearEdge[k] || vis[k] < 0.5f) continue;
    const PixelSample& p = pixels[idx[k]];
    const glm::dvec3 n = glm::normalize(glm::dvec3(p.normalWs));
    if (!(glm::dot(n, toLight) > desc.minFacing)) continue;
    const double texel = pixelTexel(p, frame);
    const double reach = desc.featureRadiusTexels * texel;
    const glm::dvec3 origin = p.posWs + std::min(0.01, 0.25 * texel) * n;
    glm::dvec3 tu, tv;
    basis(n, tu, tv);
    for (int d = 0; d < kDirections; ++d) {
      const double a = 6.283185307179586 * d / kDirections;
      const glm::dvec3 dir = std::cos(a) * tu + std::sin(a) * tv;
      // A step along the surface moves the light-space footprint by its part across the light.
      const double across = glm::length(dir - glm::dot(dir, toLight) * toLight);
      const double len = std::min(reach / std::max(across, 1e-3), 64.0 * texel);
      glm::dvec3 hit;
      if (tracer.intersect(origin, dir, &hit, nullptr) && glm::length(hit - origin) <= len) {
        nearEdge[k] = 1;  // the surface meets other geometry (a concave corner, a contact)
        break;
      }
      // Does the surface go on there? Not where it ends at a convex corner or its outline.
      const double along = std::min(len, desc.featureRadiusTexels * texel);
      const glm::dvec3 end = origin + along * dir;
      if (!tracer.intersect(end, -n, &hit, nullptr) || glm::length(hit - end) > 0.25 * along) {
        nearEdge[k] = 1;
        break;
      }
    }
  }
}

}  // namespace

BiasTruth computeBiasTruth(std::span<const PixelSample> pixels, uint32_t width, uint32_t height,
                           const csm::CascadeFrame& frame, const RayTracer& tracer,
                           const csm::DirectionalLight& light, const BiasTruthDesc& desc) {
  BiasTruth truth;
  truth.width = width;
  truth.height = height;
  truth.cls.assign(size_t(width) * height, BiasClass::kIgnored);
  const glm::dvec3 toLight = -glm::normalize(light.directionWs);
  glm::dvec3 lu, lv;
  basis(toLight, lu, lv);

  // Candidate pixels and their own visibility.
  std::vector<size_t> idx;
  std::vector<glm::dvec3> pos;
  std::vector<glm::vec3> nrm;
  for (size_t i = 0; i < pixels.size(); ++i) {
    const PixelSample& p = pixels[i];
    if (!finitePixel(p) || p.cascade < 0 || p.cascade >= int(frame.cascadeCount)) continue;
    // In the fade to lit before the shadow distance a shadow is lightened by design.
    if (csm::shadowFade(frame, csm::viewDepthM(frame, p.posWs)) > 0.0) continue;
    if (p.x >= width || p.y >= height) continue;
    if (!(glm::dot(glm::dvec3(p.normalWs), toLight) > 0.0)) continue;
    idx.push_back(i);
    pos.push_back(p.posWs);
    nrm.push_back(p.normalWs);
  }
  std::vector<float> vis(pos.size());
  tracer.visibility(pos, nrm, light.directionWs, vis);

  // Lit facing pixels: probe the truth over the disk of edgeRadius texels around them across the
  // light (a Vogel spiral of kDiskPoints: neighbours about 1.3 texels apart, so that thin shadows,
  // a pole's, cannot slip between them), each point moved along the light back onto the pixel's
  // tangent plane (what a PCF tap compares against, with a perfect receiver-plane bias): the
  // plane of the triangle under the pixel, not of its interpolated normal.
  std::vector<glm::dvec3> ringPos;
  std::vector<glm::vec3> ringNrm;
  std::vector<size_t> ringOwner;
  std::vector<uint8_t> nearEdge(idx.size(), 0);
  for (size_t k = 0; k < idx.size(); ++k) {
    const PixelSample& p = pixels[idx[k]];
    const glm::dvec3 ns = glm::normalize(glm::dvec3(p.normalWs));
    if (vis[k] < 0.5f || !(glm::dot(ns, toLight) > desc.minFacing)) continue;
    const double texel = pixelTexel(p, frame);
    const glm::dvec3 n = facetNormal(tracer, p.posWs, ns, std::min(0.01, 0.25 * texel));
    const double nl = glm::dot(n, toLight);
    if (!(nl > 1e-3)) {  // lit, yet its facet grazes the light: an edge, not counted as acne
      nearEdge[k] = 1;
      continue;
    }
    const double r = desc.edgeRadiusTexels * texel + desc.footprintRadii * p.footprintM;
    for (int d = 0; d < kDiskPoints; ++d) {
      const double a = 2.399963229728653 * d;  // golden angle
      const double rd = r * std::sqrt((d + 0.5) / kDiskPoints);
      const glm::dvec3 step = rd * (std::cos(a) * lu + std::sin(a) * lv);
      const double t = -glm::dot(n, step) / nl;
      ringPos.push_back(p.posWs + step + t * toLight);
      ringNrm.push_back(glm::vec3(n));
      ringOwner.push_back(k);
    }
  }
  std::vector<float> ringVis(ringPos.size());
  tracer.visibility(ringPos, ringNrm, light.directionWs, ringVis);
  for (size_t j = 0; j < ringPos.size(); ++j) {
    if (ringVis[j] < 0.5f) nearEdge[ringOwner[j]] = 1;
  }
  if (desc.occluders != nullptr) {
    markNearOccluders(pixels, idx, vis, frame, *desc.occluders, toLight, lu, lv, desc, nearEdge);
  }
  if (desc.surfaceFeatures)
    markSurfaceFeatures(pixels, idx, vis, frame, tracer, toLight, desc, nearEdge);

  for (size_t k = 0; k < idx.size(); ++k) {
    const PixelSample& p = pixels[idx[k]];
    BiasClass& c = truth.cls[size_t(p.y) * width + p.x];
    const glm::dvec3 n = glm::normalize(glm::dvec3(p.normalWs));
    if (vis[k] >= 0.5f) {
      if (glm::dot(n, toLight) > desc.minFacing) {
        c = nearEdge[k] ? BiasClass::kLitNearEdge : BiasClass::kLitInterior;
      }
      continue;
    }
    // Shadowed: is other geometry within contactTexels along the surface?
    const double texel = pixelTexel(p, frame);
    const double lift = std::min(0.01, 0.25 * texel);
    const double reach = desc.contactTexels * texel;
    glm::dvec3 tu, tv;
    basis(n, tu, tv);
    const glm::dvec3 origin = p.posWs + lift * n;
    bool contact = false;
    for (int d = 0; d < kDirections && !contact; ++d) {
      const double a = 6.283185307179586 * d / kDirections;
      const glm::dvec3 dir = std::cos(a) * tu + std::sin(a) * tv;
      glm::dvec3 hit;
      if (tracer.intersect(origin, dir, &hit, nullptr) && glm::length(hit - origin) <= reach) {
        contact = true;
      }
    }
    c = contact ? BiasClass::kShadowContact : BiasClass::kShadowOther;
  }
  return truth;
}

BiasStats scoreBias(std::span<const PixelSample> pixels, const BiasTruth& truth,
                    const csm::DirectionalLight& light, double minFacing) {
  BiasStats st;
  const glm::dvec3 toLight = -glm::normalize(light.directionWs);
  std::vector<uint8_t> seen(truth.cls.size(), 0);
  for (const PixelSample& p : pixels) {
    if (p.x >= truth.width || p.y >= truth.height) continue;
    seen[size_t(p.y) * truth.width + p.x] = 1;
    const BiasClass c = truth.at(p.x, p.y);
    if (c == BiasClass::kIgnored) continue;
    if (!std::isfinite(p.shadow)) {
      ++st.nonFinite;
      continue;
    }
    const bool dark = p.shadow < 0.5f;
    switch (c) {
      case BiasClass::kLitInterior:
        ++st.litInterior;
        st.litInteriorDark += dark ? 1 : 0;
        st.litInteriorDimmed += p.shadow < 0.9f ? 1 : 0;
        st.litInteriorBelow099 += p.shadow < 0.99f ? 1 : 0;
        [[fallthrough]];
      case BiasClass::kLitNearEdge:
        ++st.litFacing;
        st.litFacingDark += dark ? 1 : 0;
        break;
      case BiasClass::kShadowContact:
        ++st.contact;
        st.contactLit += p.shadow > 0.5f ? 1 : 0;
        if (glm::dot(glm::normalize(glm::dvec3(p.normalWs)), toLight) > minFacing) {
          ++st.contactFacing;
          st.contactFacingLit += p.shadow > 0.5f ? 1 : 0;
        }
        break;
      default:
        break;
    }
  }
  for (size_t i = 0; i < seen.size(); ++i) {
    if (!seen[i] && truth.cls[i] != BiasClass::kIgnored) ++st.unmatched;
  }
  return st;
}

nlohmann::json BiasStats::toJson() const {
  return {{"lit_facing", litFacing},
          {"lit_facing_dark", litFacingDark},
          {"lit_interior", litInterior},
          {"lit_interior_dark", litInteriorDark},
          {"lit_interior_dimmed", litInteriorDimmed},
          {"lit_interior_below_099", litInteriorBelow099},
          {"contact", contact},
          {"contact_lit", contactLit},
          {"contact_facing", contactFacing},
          {"contact_facing_lit", contactFacingLit},
          {"non_finite", nonFinite},
          {"unmatched", unmatched}};
}

void paintBiasErrors(engine::CpuImage& image, std::span<const PixelSample> pixels,
                     const BiasTruth& truth) {
  for (const PixelSample& p : pixels) {
    if (p.x >= image.width || p.y >= image.height) continue;
    uint8_t* px = &image.rgba[4 * (size_t(p.y) * image.width + p.x)];
    const BiasClass c = truth.at(p.x, p.y);
    const bool dark = !(p.shadow >= 0.5f);
    if (c == BiasClass::kLitInterior && dark) {
      px[0] = 255, px[1] = 0, px[2] = 0;
    } else if (c == BiasClass::kLitNearEdge && dark) {
      px[0] = 120, px[1] = 0, px[2] = 0;
    } else if (c == BiasClass::kShadowContact) {
      if (p.shadow > 0.5f) {
        px[0] = 0, px[1] = 0, px[2] = 255;
      } else {
        px[2] = uint8_t(std::min(255, px[2] + 60));
        px[1] = uint8_t(std::min(255, px[1] + 30));
      }
    }
  }
}

}  // namespace csm_measure
