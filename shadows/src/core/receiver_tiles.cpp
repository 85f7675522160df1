#include "csm/receiver_tiles.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "csm/cache_rects.hpp"
#include "csm/gpu_layout.hpp"
#include "csm/moments.hpp"

namespace csm {

std::uint32_t ReceiverTileMarks::markedCount(std::uint32_t i) const noexcept {
  std::uint32_t n = 0;
  if (i >= kMaxCascades) return 0;
  for (std::uint32_t w : bits[i]) n += std::uint32_t(std::popcount(w));
  return n;
}

double receiverSampleReachTexels(const ShadowSettings& settings, const CascadeFrame& frame,
                                 std::uint32_t i) noexcept {
  if (i >= frame.cascadeCount || i >= kMaxCascades || frame.cascades[i].empty) return 0.0;
  const double texel = frame.cascades[i].texelSizeM();
  if (!(texel > 0.0)) return 0.0;
  const double offset = double(settings.normalOffsetTexels) * std::sqrt(2.0);
  const PcfKernel k = settings.kernel;
  if (k == PcfKernel::kPcss) {
    const double search = std::max(0.5 * settings.maxPenumbraM / texel, 1.0);
    return search + double(CSM_KERNEL_RADIUS_PCSS);
  }
  if (isPrefiltered(k)) {
    return double(CSM_KERNEL_RADIUS_MOMENTS) +
           double(momentBlurRadiusTexels(settings.momentBlurM, texel)) + offset;
  }
  // The taps spread by the world-space kernel's scale: reach 1 + (radius - 1) s.
  const double texel0 = frame.cascades[0].texelSizeM();
  const double scale = settings.worldSpaceKernel && texel0 > 0.0 ? texel0 / texel : 1.0;
  return 1.0 + (double(kernelRadiusTexels(k)) - 1.0) * scale + offset;
}

ReceiverTileMarks emptyReceiverTileMarks(const ShadowSettings& settings,
                                         const CascadeFrame& frame) noexcept {
  ReceiverTileMarks m;
  const std::uint32_t count = std::min(frame.cascadeCount, kMaxCascades);
  const std::uint32_t res = frame.resolution > 0 ? frame.resolution : settings.resolution;
  m.cascadeCount = count;
  m.tileTexels = std::max(res / kTilesPerSide, 1u);
  m.splitsM = frame.splitsM;
  m.lightBasisWs = frame.lightBasisWs;
  m.cameraPositionWs = frame.cameraPositionWs;
  const glm::dmat3 basisT = glm::transpose(frame.lightBasisWs);
  const double band = settings.blendBand;
  for (std::uint32_t i = 0; i < count; ++i) {
    const Cascade& c = frame.cascades[i];
    const double nearM = frame.splitsM[i], farM = frame.splitsM[i + 1];
    m.blendStartM[i] = farM - band * (farM - nearM);
    if (c.empty || !(c.texelSizeM() > 0.0)) continue;
    m.nonEmptyMask |= 1u << i;
    const double texel = c.texelSizeM();
    m.texelM[i] = texel;
    m.reachM[i] = receiverSampleReachTexels(settings, frame, i) * texel;
    // The box's first world texel, as the cached renderer's windows place it, and its tile.
    const glm::dvec3 centerLs = basisT * c.boxCenterWs;
    const auto half = std::int64_t(res / 2);
    const std::int64_t boxX = std::llround(std::clamp(centerLs.x / texel, -4e18, 4e18)) - half;
    const std::int64_t boxY = std::llround(std::clamp(centerLs.y / texel, -4e18, 4e18)) - half;
    m.gridOrigin[i] = glm::i64vec2(floorDiv(boxX, m.tileTexels), floorDiv(boxY, m.tileTexels));
  }
  return m;
}

std::pair<int, int> shadingCascades(const ReceiverTileMarks& m, double viewDepthM) noexcept {
  int c = -1;
  for (std::uint32_t i = 0; i < m.cascadeCount; ++i) {
    if ((m.nonEmptyMask >> i & 1u) && viewDepthM >= m.splitsM[i] && viewDepthM < m.splitsM[i + 1]) {
      c = int(i);
      break;
    }
  }
  if (c < 0) return {-1, -1};
  const auto i = std::uint32_t(c);
  const std::uint32_t next = i + 1;
  if (next < m.cascadeCount && (m.nonEmptyMask >> next & 1u) &&
      m.blendStartM[i] < m.splitsM[i + 1] && viewDepthM >= m.blendStartM[i]) {
    return {c, int(next)};
  }
  return {c, -1};
}

void markTileRect(ReceiverTileMarks& m, std::uint32_t i, const glm::dvec2& minLs,
                  const glm::dvec2& maxLs) noexcept {
  if (i >= m.cascadeCount || !(m.nonEmptyMask >> i & 1u)) return;
  const double tileM = m.texelM[i] * m.tileTexels;
  const glm::dvec2 origin = glm::dvec2(m.gridOrigin[i]) * tileM;
  const double side = double(kTileGridSide);
  const glm::dvec2 lo = glm::floor((minLs - m.reachM[i] - origin) / tileM);
  const glm::dvec2 hi = glm::floor((maxLs + m.reachM[i] - origin) / tileM);
  if (!(hi.x >= 0.0 && hi.y >= 0.0 && lo.x < side && lo.y < side)) return;
  const auto x0 = std::uint32_t(std::max(lo.x, 0.0)), y0 = std::uint32_t(std::max(lo.y, 0.0));
  const auto x1 = std::uint32_t(std::min(hi.x, side - 1.0));
  const auto y1 = std::uint32_t(std::min(hi.y, side - 1.0));
  for (std::uint32_t y = y0; y <= y1; ++y) {
    for (std::uint32_t x = x0; x <= x1; ++x) m.mark(i, x, y);
  }
}

int markReceiverTiles(ReceiverTileMarks& m, const glm::dvec3& posWs, double viewDepthM) noexcept {
  const auto [c, next] = shadingCascades(m, viewDepthM);
  if (c < 0) return -1;
  const glm::dvec3 q = glm::transpose(m.lightBasisWs) * posWs;
  const glm::dvec2 ls(q.x, q.y);
  markTileRect(m, std::uint32_t(c), ls, ls);
  if (next >= 0) markTileRect(m, std::uint32_t(next), ls, ls);
  return c;
}

std::uint32_t TileMask::count() const noexcept {
  std::uint32_t n = 0;
  for (std::uint32_t w : bits) n += std::uint32_t(std::popcount(w));
  return n;
}

void carryTileMarks(const ReceiverTileMarks& m, std::uint32_t i, const glm::dmat3& basis,
                    double texelM, std::int64_t tileTexels, double zNearLs, double zFarLs,
                    TileMask& mask, const glm::dvec3& shiftWs) noexcept {
  mask.bits = {};
  if (i >= m.cascadeCount || !(m.nonEmptyMask >> i & 1u) || m.tileTexels == 0 || tileTexels <= 0 ||
      !(texelM > 0.0) || !(m.texelM[i] > 0.0)) {
    return;
  }
  const glm::i64vec2 shift = m.gridOrigin[i] - mask.origin;
  if (m.lightBasisWs == basis && m.texelM[i] == texelM &&
      std::int64_t(m.tileTexels) == tileTexels && shiftWs == glm::dvec3(0.0)) {
    // The same world tiles: only the grids' origins differ.
    for (std::uint32_t y = 0; y < kTileGridSide; ++y) {
      for (std::uint32_t x = 0; x < kTileGridSide; ++x) {
        if (m.marked(i, x, y)) mask.set(shift.x + x, shift.y + y);
      }
    }
    return;
  }
  // Each marked column's eight corners, from the marks' light space to this one's.
  const glm::dmat3 toNew = glm::transpose(basis) * m.lightBasisWs;
  const glm::dvec3 shiftLs = glm::transpose(m.lightBasisWs) * shiftWs;
  const double oldTileM = m.texelM[i] * double(m.tileTexels);
  const double newTileM = texelM * double(tileTexels);
  const glm::dvec2 newOrigin = glm::dvec2(mask.origin) * newTileM;
  const double side = double(kTileGridSide);
  for (std::uint32_t y = 0; y < kTileGridSide; ++y) {
    for (std::uint32_t x = 0; x < kTileGridSide; ++x) {
      if (!m.marked(i, x, y)) continue;
      const glm::dvec2 lo = glm::dvec2(m.gridOrigin[i] + glm::i64vec2(x, y)) * oldTileM;
      glm::dvec2 mn(1e300), mx(-1e300);
      for (int k = 0; k < 8; ++k) {
        const glm::dvec3 p(lo.x + ((k & 1) ? oldTileM : 0.0), lo.y + ((k & 2) ? oldTileM : 0.0),
                           (k & 4) ? zFarLs : zNearLs);
        const glm::dvec3 q = toNew * (p + shiftLs);
        mn = glm::min(mn, glm::dvec2(q));
        mx = glm::max(mx, glm::dvec2(q));
      }
      const glm::dvec2 a = glm::floor((mn - newOrigin) / newTileM);
      const glm::dvec2 b = glm::floor((mx - newOrigin) / newTileM);
      if (!(b.x >= 0.0 && b.y >= 0.0 && a.x < side && a.y < side)) continue;
      const auto x0 = std::int64_t(std::max(a.x, 0.0)), y0 = std::int64_t(std::max(a.y, 0.0));
      const auto x1 = std::int64_t(std::min(b.x, side - 1.0));
      const auto y1 = std::int64_t(std::min(b.y, side - 1.0));
      for (std::int64_t ty = y0; ty <= y1; ++ty) {
        for (std::int64_t tx = x0; tx <= x1; ++tx) mask.set(tx, ty);
      }
    }
  }
}

namespace {

// Widens [lo, hi] to hold the x of segment a-b where its y lies in [y0, y1].
void clipToBand(const glm::dvec2& a, const glm::dvec2& b, double y0, double y1, double& lo,
                double& hi) noexcept {
  double t0 = 0.0, t1 = 1.0;
  const double dy = b.y - a.y;
  if (dy == 0.0) {
    if (a.y < y0 || a.y > y1) return;
  } else {
    const double ta = (y0 - a.y) / dy, tb = (y1 - a.y) / dy;
    t0 = std::max(t0, std::min(ta, tb));
    t1 = std::min(t1, std::max(ta, tb));
    if (t0 > t1) return;
  }
  const double x0 = a.x + (b.x - a.x) * t0, x1 = a.x + (b.x - a.x) * t1;
  lo = std::min({lo, x0, x1});
  hi = std::max({hi, x0, x1});
}

}  // namespace

bool markFrustumTiles(const CascadeFrame& frame, double nearM, double farM, const glm::dmat3& basis,
                      double texelM, std::int64_t tileTexels, double reachM,
                      TileMask& mask) noexcept {
  mask.bits = {};
  const double tanY = frame.cameraTanHalfFovY;
  const double tanX = tanY * frame.cameraAspect;
  if (!(tanY > 0.0) || !(tanX > 0.0) || !std::isfinite(tanX) || !(nearM >= 0.0) ||
      !(farM >= nearM) || !std::isfinite(farM) || !(texelM > 0.0) || !std::isfinite(texelM) ||
      tileTexels <= 0 || !(reachM >= 0.0) || !std::isfinite(reachM)) {
    return false;
  }
  // The section's 8 corners in light space, about the camera (exact at any distance from the
  // origin), and the camera's light-space x, y relative to the grid's first tile.
  const glm::dmat3 basisT = glm::transpose(basis);
  const glm::dvec3 fwd = frame.cameraForwardWs;
  const glm::dvec3 up = frame.cameraUpWs;
  const glm::dvec3 right = glm::cross(fwd, up);
  const double tileM = texelM * double(tileTexels);
  const glm::dvec3 camLs = basisT * frame.cameraPositionWs;
  const glm::dvec2 cam = glm::dvec2(camLs.x, camLs.y) - glm::dvec2(mask.origin) * tileM;
  std::array<glm::dvec2, 8> corners;
  std::size_t n = 0;
  for (const double d : {nearM, farM}) {
    for (const double sx : {-1.0, 1.0}) {
      for (const double sy : {-1.0, 1.0}) {
        const glm::dvec3 q = basisT * (fwd * d + right * (sx * tanX * d) + up * (sy * tanY * d));
        corners[n++] = cam + glm::dvec2(q.x, q.y);
      }
    }
  }
  for (const glm::dvec2& c : corners) {
    if (!std::isfinite(c.x) || !std::isfinite(c.y)) return false;
  }
  // The outline is the convex hull of the corners, so its section by a row's band is that of
  // the segments between every two corners (each lies in the hull; the hull's edges are among
  // them). A tile is touched where the band's x extent meets its own, both widened.
  const double widen = reachM + texelM;
  for (std::int64_t y = 0; y < kTileGridSide; ++y) {
    const double y0 = double(y) * tileM - widen, y1 = double(y + 1) * tileM + widen;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (std::size_t a = 0; a < corners.size(); ++a) {
      for (std::size_t b = a; b < corners.size(); ++b)
        clipToBand(corners[a], corners[b], y0, y1, lo, hi);
    }
    if (!(lo <= hi)) continue;
    for (std::int64_t x = 0; x < kTileGridSide; ++x) {
      const double x0 = double(x) * tileM - widen, x1 = double(x + 1) * tileM + widen;
      if (x1 >= lo && x0 <= hi) mask.set(x, y);
    }
  }
  return true;
}

}  // namespace csm
