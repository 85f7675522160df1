// Shadow-bias metrics against the ray-traced truth: acne (false shadow on lit surfaces that face
// the light) and leaks / peter-panning (false light next to contact lines, where a caster meets its
// receiver). The truth depends only on the pixels' positions, the frame's texel sizes and the
// light, so it is computed once per view and scored against every kernel and depth format.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <span>
#include <vector>

#include "csm_measure/harness.hpp"
#include "csm_measure/raytracer.hpp"

namespace csm_measure {

/// What the truth says about one receiver pixel, for the bias metrics.
enum class BiasClass : uint8_t {
  kIgnored = 0,        ///< outside every cascade, N.L <= 0.1 and not near a contact, or not finite
  kLitInterior = 1,    ///< faces the light (N.L > 0.1), lit, and lit all around (no edge within
                       ///< edgeRadiusTexels): any darkening here is acne
  kLitNearEdge = 2,    ///< faces the light and lit, but a true shadow edge lies within reach
  kShadowContact = 3,  ///< in shadow and within contactTexels of a contact line (leak candidate)
  kShadowOther = 4,    ///< in shadow, away from contacts
};

/// How far a prefiltered filter read at its footprint's mip reaches, in pixel footprints (the
/// value of BiasTruthDesc::footprintRadii for vsm, evsm and msm under HarnessDesc::implicitLod):
/// a trilinear tap reads the mip of the footprint's long axis and the next, whose bilinear texels
/// reach about twice that axis from the centre; the long axis is about twice the square root of
/// the footprint's area at 60 degrees of incidence.
inline constexpr double kMipFootprintRadii = 4.0;

/// How the truth classifies pixels.
struct BiasTruthDesc {
  /// Smallest N.L of a pixel that counts as facing the light (the 0.1).
  double minFacing = 0.1;
  /// A lit pixel with a true shadow within this many texels (of its cascade, measured across the
  /// light in light space; 64 points over the disk) is "near an edge": PCF blurs edges by the
  /// kernel's reach, so darkening there is filtering, not acne. 6 = the widest kernel (tent
  /// 7x7, 3.5) + bilinear (1) + margin.
  double edgeRadiusTexels = 6.0;
  /// For a filter that averages over the pixel's footprint (the prefiltered filters read at the
  /// footprint's mip): the edge radius grows by this many times the pixel's footprint
  /// (PixelSample::footprintM, the square root of its area on the surface). 0: the lookup's reach
  /// does not depend on the pixel (the percentage-closer kernels).
  double footprintRadii = 0.0;
  /// Contact lines: a shadowed pixel with other geometry within this many texels along its own
  /// surface (8 directions in the tangent plane) lies next to a contact line.
  double contactTexels = 2.0;
  /// Optional: the scene, whose instances other than the ground are potential occluders. A lit
  /// pixel is also "near an edge" when such an instance's bounds, seen along the light, come
  /// within edgeRadiusTexels of it and reach in front of its plane (toward the light): a caster
  /// thinner than the disk's spacing (a 8 cm pole under 25 cm texels) casts a shadow the disk
  /// probe can miss, yet every kernel blurs it over its reach. Null: the disk probe alone.
  const Scene* occluders = nullptr;
  /// A lit pixel is also "near an edge" when its own surface meets other geometry or ends within
  /// the lookup's reach: a ray along the surface (8 directions in its plane, each as long as
  /// featureRadiusTexels seen across the light, at most 64 texels) hits something (the terrain
  /// at the foot of a lit wall, whose texels a wide kernel reads in front of the wall's plane),
  /// or the surface is not found under the ray's end, within featureRadiusTexels (a building's
  /// corner, beyond which the normal offset carries the lookup).
  bool surfaceFeatures = false;
  /// The widest lookup: tent 7x7 reads 4 texels about a point that the normal offset moves by
  /// up to 1.25 x (|n_x| + |n_y|) <= 1.8 texels across the light (csmShadowCoord): 6 texels.
  double featureRadiusTexels = 6.0;
};

/// Truth per pixel of one view (index y * width + x; pixels not drawn are kIgnored).
struct BiasTruth {
  uint32_t width = 0, height = 0;
  std::vector<BiasClass> cls;
  [[nodiscard]] BiasClass at(uint32_t x, uint32_t y) const {
    return x < width && y < height ? cls[size_t(y) * width + x] : BiasClass::kIgnored;
  }
};

/// Classifies every pixel of `pixels` (from Harness::renderAccuracy over `width` x `height`).
BiasTruth computeBiasTruth(std::span<const PixelSample> pixels, uint32_t width, uint32_t height,
                           const csm::CascadeFrame& frame, const RayTracer& tracer,
                           const csm::DirectionalLight& light, const BiasTruthDesc& desc = {});

/// Counts of one scored view.
struct BiasStats {
  uint64_t litFacing = 0;      ///< kLitInterior + kLitNearEdge
  uint64_t litFacingDark = 0;  ///< of those, shaded < 0.5 (the issue's raw definition)
  uint64_t litInterior = 0;
  uint64_t litInteriorDark = 0;  ///< acne: interior lit pixels shaded < 0.5
  /// Interior lit pixels shaded < 0.9: faint acne (dots of 0.8) that the 0.5 threshold misses.
  uint64_t litInteriorDimmed = 0;
  /// Interior lit pixels shaded < 0.99: any visible darkening (a 0.9 stipple crawls when the
  /// camera moves); the issue-24 acne measure.
  uint64_t litInteriorBelow099 = 0;
  uint64_t contact = 0;     ///< kShadowContact
  uint64_t contactLit = 0;  ///< leaks: of those, shaded > 0.5
  /// Contact pixels that face the light (N.L > minFacing), where shading can show a leak, and
  /// those of them shaded > 0.5.
  uint64_t contactFacing = 0;
  uint64_t contactFacingLit = 0;
  uint64_t nonFinite = 0;  ///< shadow factors that are NaN / inf
  uint64_t unmatched = 0;  ///< pixels whose truth class is missing (different raster)
  /// Acne as a fraction of the interior lit pixels.
  [[nodiscard]] double acne() const noexcept {
    return litInterior ? double(litInteriorDark) / double(litInterior) : 0.0;
  }
  /// Faint acne: interior lit pixels shaded < 0.9.
  [[nodiscard]] double dimmed() const noexcept {
    return litInterior ? double(litInteriorDimmed) / double(litInterior) : 0.0;
  }
  /// "false_shadow_below_099": interior lit pixels shaded < 0.99.
  [[nodiscard]] double below099() const noexcept {
    return litInterior ? double(litInteriorBelow099) / double(litInterior) : 0.0;
  }
  /// The raw "false_shadow_lit_facing" (edges included).
  [[nodiscard]] double acneRaw() const noexcept {
    return litFacing ? double(litFacingDark) / double(litFacing) : 0.0;
  }
  /// "false_lit_near_contact".
  [[nodiscard]] double leaks() const noexcept {
    return contact ? double(contactLit) / double(contact) : 0.0;
  }
  /// Leaks where the surface faces the light (N.L > 0.1).
  [[nodiscard]] double leaksFacing() const noexcept {
    return contactFacing ? double(contactFacingLit) / double(contactFacing) : 0.0;
  }
  [[nodiscard]] nlohmann::json toJson() const;
};

/// Scores a rendered view against its truth.
BiasStats scoreBias(std::span<const PixelSample> pixels, const BiasTruth& truth,
                    const csm::DirectionalLight& light, double minFacing = 0.1);

/// Paints the view's misclassifications over `image` (from renderAccuracy): acne red, leaks
/// blue, near-edge darkening dark red (not counted as acne), contact pixels a faint cyan.
void paintBiasErrors(engine::CpuImage& image, std::span<const PixelSample> pixels,
                     const BiasTruth& truth);

}  // namespace csm_measure
