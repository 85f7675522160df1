// csm_flythrough: what report.json says of a frame.
#include "flythrough_app.hpp"

#include <cmath>
#include <cstdint>
#include <cstdlib>

namespace flythrough {

json finiteOrNull(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

std::pair<double, double> shadowedFraction(const engine::CpuImage& img) {
  std::uint64_t geometry = 0, shadowed = 0;
  for (std::uint32_t y = 0; y < img.height; ++y) {
    for (std::uint32_t x = 0; x < img.width; ++x) {
      const auto p = img.at(x, y);
      if (std::abs(int(p[0]) - int(p[1])) > 2 || std::abs(int(p[1]) - int(p[2])) > 2) continue;
      ++geometry;
      if (p[0] < 128) ++shadowed;
    }
  }
  const double total = double(img.width) * img.height;
  return {geometry ? double(shadowed) / double(geometry) : 0.0, double(geometry) / total};
}

json cascadesJson(const world::FrameStats& st) {
  json arr = json::array();
  for (std::uint32_t c = 0; c < st.cascadeCount; ++c) {
    const csm::Cascade& cs = st.cascades.cascades[c];
    arr.push_back({{"split_near_m", cs.splitNearM},
                   {"split_far_m", cs.splitFarM},
                   {"sphere_radius_m", cs.sphereRadiusM},
                   {"texel_m", cs.texelSizeM()},
                   {"empty", cs.empty},
                   {"lod", st.lod[c]},
                   {"casters", st.casters[c]},
                   {"triangles", st.triangles[c]},
                   {"texels_rendered", st.texelsRendered[c]}});
  }
  return arr;
}

}  // namespace flythrough
