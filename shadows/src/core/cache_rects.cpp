#include "csm/cache_rects.hpp"

#include <algorithm>
#include <cmath>

namespace csm {

TexelRect TexelRect::intersect(const TexelRect& o) const noexcept {
  return {std::max(x0, o.x0), std::max(y0, o.y0), std::min(x1, o.x1), std::min(y1, o.y1)};
}

std::uint64_t TexelRect::area() const noexcept {
  return empty() ? 0 : std::uint64_t(x1 - x0) * std::uint64_t(y1 - y0);
}

TexelRect boxTexels(const AabbWs& box, const glm::dmat3& basisT, double texel,
                    float marginTexels) noexcept {
  double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
  for (int k = 0; k < 8; ++k) {
    const glm::dvec3 p((k & 1) ? box.maxWs.x : box.minWs.x, (k & 2) ? box.maxWs.y : box.minWs.y,
                       (k & 4) ? box.maxWs.z : box.minWs.z);
    const glm::dvec3 q = basisT * p;
    for (int a = 0; a < 2; ++a) {
      lo[a] = std::min(lo[a], q[a]);
      hi[a] = std::max(hi[a], q[a]);
    }
  }
  auto toIndex = [&](double v) {
    return static_cast<std::int64_t>(std::clamp(std::floor(v / texel), -4e18, 4e18));
  };
  const std::int64_t m = 1 + static_cast<std::int64_t>(std::ceil(marginTexels));
  return {toIndex(lo[0]) - m, toIndex(lo[1]) - m, toIndex(hi[0]) + 1 + m, toIndex(hi[1]) + 1 + m};
}

bool staleRects(bool valid, const TexelRect& old, const TexelRect& box,
                const std::vector<AabbWs>& pending, const glm::dmat3& basisT, double texel,
                std::vector<TexelRect>& out) {
  out.clear();
  if (valid) {
    if (box.x0 < old.x0) out.push_back({box.x0, box.y0, std::min(old.x0, box.x1), box.y1});
    if (box.x1 > old.x1) out.push_back({std::max(old.x1, box.x0), box.y0, box.x1, box.y1});
    const std::int64_t ox0 = std::max(box.x0, old.x0), ox1 = std::min(box.x1, old.x1);
    if (box.y0 < old.y0) out.push_back({ox0, box.y0, ox1, std::min(old.y0, box.y1)});
    if (box.y1 > old.y1) out.push_back({ox0, std::max(old.y1, box.y0), ox1, box.y1});
    for (const AabbWs& b : pending) {
      const TexelRect r = boxTexels(b, basisT, texel).intersect(box);
      if (!r.empty()) out.push_back(r);
    }
    std::erase_if(out, [](const TexelRect& r) { return r.empty(); });
    if (totalArea(out) < box.area()) return false;
  }
  out.assign(1, box);
  return true;
}

void addDisjoint(std::vector<TexelRect>& rects, const TexelRect& r) {
  std::vector<TexelRect> remaining{r}, next;
  std::erase_if(remaining, [](const TexelRect& t) { return t.empty(); });
  for (const TexelRect& p : rects) {
    if (remaining.empty()) return;
    next.clear();
    for (const TexelRect& t : remaining) {
      const TexelRect o = t.intersect(p);
      if (o.empty()) {
        next.push_back(t);
        continue;
      }
      // t minus o: the rows above and below o, then the columns beside it.
      if (t.y0 < o.y0) next.push_back({t.x0, t.y0, t.x1, o.y0});
      if (o.y1 < t.y1) next.push_back({t.x0, o.y1, t.x1, t.y1});
      if (t.x0 < o.x0) next.push_back({t.x0, o.y0, o.x0, o.y1});
      if (o.x1 < t.x1) next.push_back({o.x1, o.y0, t.x1, o.y1});
    }
    std::swap(remaining, next);
  }
  rects.insert(rects.end(), remaining.begin(), remaining.end());
}

std::uint64_t totalArea(const std::vector<TexelRect>& rects) noexcept {
  std::uint64_t sum = 0;
  for (const TexelRect& r : rects) sum += r.area();
  return sum;
}

void splitIntoLayer(std::int64_t anchorX, std::int64_t anchorY, std::int64_t res,
                    const TexelRect& r, std::vector<LayerRect>& out) {
  out.clear();
  if (r.empty()) return;
  for (std::int64_t mx = floorDiv(r.x0 - anchorX, res); mx <= floorDiv(r.x1 - 1 - anchorX, res);
       ++mx) {
    for (std::int64_t my = floorDiv(r.y0 - anchorY, res); my <= floorDiv(r.y1 - 1 - anchorY, res);
         ++my) {
      const TexelRect block{anchorX + mx * res, anchorY + my * res, anchorX + (mx + 1) * res,
                            anchorY + (my + 1) * res};
      const TexelRect part = r.intersect(block);
      if (part.empty()) continue;
      out.push_back(
          {part,
           mx,
           my,
           {part.x0 - block.x0, part.y0 - block.y0, part.x1 - block.x0, part.y1 - block.y0}});
    }
  }
}

}  // namespace csm
