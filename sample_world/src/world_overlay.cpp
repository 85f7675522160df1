// The sample world's overlay (see world_renderer.hpp): the cascade thumbnails and the map,
// drawn in the frame's rendering after the shading.
#include "sample_world/world_renderer.hpp"

#include <csm_shaders/overlay_2d.frag.spv.h>
#include <csm_shaders/overlay_2d.vert.spv.h>
#include <csm_shaders/world.frag.spv.h>
#include <csm_shaders/world.vert.spv.h>
#include <csm_shaders/world_deferred.frag.spv.h>
#include <csm_shaders/world_deferred.vert.spv.h>
#include <csm_shaders/world_gbuffer.frag.spv.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "csm/gpu_layout.hpp"
#include "csm/names.hpp"
#include "engine/debug.hpp"
#include "engine/errors.hpp"
#include "glue/camera.hpp"
#include "glue/shadow_host.hpp"
#include "glue/vk_util.hpp"
#include "world_renderer_internal.hpp"

namespace world {

void WorldRenderer::recordOverlay(const engine::Frame& f, Slot& slot, engine::GpuTimer& timer) {
  VkCommandBuffer cmd = f.cmd;
  const VkDeviceSize zero = 0;
  timer.begin(cmd, "overlay");
  engine::ScopedLabel label(cmd, "overlay 2d", {0.3f, 0.9f, 0.9f, 1.0f});
  std::vector<OverlayVertex> tris, lines;
  buildOverlay(f.extent, tris, lines);
  const std::size_t total = std::min<std::size_t>(tris.size() + lines.size(), kMaxOverlayVertices);
  tris.resize(std::min(tris.size(), total));
  lines.resize(std::min(lines.size(), total - tris.size()) & ~std::size_t(1));
  auto* dst = static_cast<OverlayVertex*>(slot.overlay.mapped());
  std::memcpy(dst, tris.data(), tris.size() * sizeof(OverlayVertex));
  std::memcpy(dst + tris.size(), lines.data(), lines.size() * sizeof(OverlayVertex));
  const glm::vec2 inv(1.0f / f.extent.width, 1.0f / f.extent.height);
  const VkBuffer ovb = slot.overlay.handle();
  const VkDescriptorSet set = shadow_->lightingSet();
  vkCmdBindVertexBuffers(cmd, 0, 1, &ovb, &zero);
  for (int k = 0; k < 2; ++k) {
    const engine::GraphicsPipeline& p = k == 0 ? overlayTris_ : overlayLines_;
    const std::size_t count = k == 0 ? tris.size() : lines.size();
    if (count == 0) continue;
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.pipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.layout, 0, 1, &set, 0, nullptr);
    vkCmdPushConstants(cmd, p.layout, VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(inv), &inv);
    vkCmdDraw(cmd, static_cast<std::uint32_t>(count), 1,
              k == 0 ? 0u : static_cast<std::uint32_t>(tris.size()), 0);
  }
  timer.end(cmd, "overlay");
}

void WorldRenderer::buildOverlay(VkExtent2D extent, std::vector<OverlayVertex>& tris,
                                 std::vector<OverlayVertex>& lines) const {
  const csm::CascadeFrame& cascades = shadow_->frame();
  const csm::CullResult& culled = shadow_->cull();
  const glm::vec4 solid(-1.0f, 0.0f, 1.0f, 0.0f);
  auto quad = [&](glm::vec2 a, glm::vec2 b, glm::vec4 color, glm::vec4 thumb,
                  glm::vec3 relief = glm::vec3(0.0f)) {
    const OverlayVertex v00{a, {0, 0}, color, thumb, relief};
    const OverlayVertex v10{{b.x, a.y}, {1, 0}, color, thumb, relief};
    const OverlayVertex v01{{a.x, b.y}, {0, 1}, color, thumb, relief};
    const OverlayVertex v11{b, {1, 1}, color, thumb, relief};
    tris.insert(tris.end(), {v00, v10, v11, v00, v11, v01});
  };
  auto line = [&](glm::vec2 a, glm::vec2 b, glm::vec4 color) {
    lines.push_back({a, {0, 0}, color, solid, glm::vec3(0.0f)});
    lines.push_back({b, {0, 0}, color, solid, glm::vec3(0.0f)});
  };
  const auto W = static_cast<float>(extent.width), H = static_cast<float>(extent.height);
  const std::uint32_t n = cascades.cascadeCount;
  const float pad = std::max(4.0f, 0.01f * H);

  // Shadow-map thumbnails along the bottom-left, each framed in its cascade's tint.
  if (settings_.overlayThumbnails) {
    const float size = std::min(0.2f * H, (0.55f * W - pad * (n + 1)) / std::max(1u, n));
    for (std::uint32_t c = 0; c < n; ++c) {
      const csm::Cascade& cs = cascades.cascades[c];
      const glm::vec4 tint(csm::cascadeTint(static_cast<int>(c)), 1.0f);
      const glm::vec2 a(pad + c * (size + pad), H - pad - size);
      quad(a - glm::vec2(2.0f), a + glm::vec2(size + 2.0f), tint, solid);
      if (cs.empty) {
        quad(a, a + glm::vec2(size), {0.1f, 0.1f, 0.1f, 1.0f}, solid);
        continue;
      }
      // World height above the sphere's centre of what box texel t holds at stored depth d:
      // linear in (t, d), from the inverse of the cascade's matrix (shadow clip ->
      // camera-relative).
      const glm::dmat4 toCr = glm::inverse(glm::dmat4(cs.viewProjCr));
      const double perTexel = 2.0 / static_cast<double>(cascades.resolution);
      const glm::vec3 relief(static_cast<float>(toCr[0].y * perTexel),
                             static_cast<float>(toCr[1].y * perTexel),
                             static_cast<float>(toCr[2].y));
      const double base =
          toCr[3].y - toCr[0].y - toCr[1].y + cascades.cameraPositionWs.y - cs.sphereCenterWs.y;
      // The layer the lighting reads: with a prefiltered filter, the moment layer (its colour's
      // alpha, 2 + the kernel, tells overlay_2d.frag which moments they are).
      const csm::PcfKernel kernel = shadow_->settings().kernel;
      const float source = csm::isPrefiltered(kernel) ? 2.0f + static_cast<float>(kernel) : 1.0f;
      quad(a, a + glm::vec2(size), glm::vec4(glm::vec3(1.0f), source),
           {static_cast<float>(c), static_cast<float>(base), static_cast<float>(cs.sphereRadiusM),
            size},
           relief);
    }
  }

  // Top-down map (north up: -z up, +x right) around the camera, covering the shadow distance.
  if (settings_.overlayMap) {
    const float size = std::min(0.42f * H, 0.3f * W);
    const glm::vec2 origin(W - pad - size, H - pad - size);
    quad(origin, origin + glm::vec2(size), {0.0f, 0.0f, 0.0f, 0.55f}, solid);
    const double radius = std::max(50.0, 1.05 * cascades.shadowFarM);
    const glm::dvec3 cam = cascades.cameraPositionWs;
    auto toMap = [&](const glm::dvec3& p) {
      const glm::dvec2 d((p.x - cam.x) / radius, (p.z - cam.z) / radius);
      return origin +
             glm::vec2(static_cast<float>(0.5 + 0.5 * d.x), static_cast<float>(0.5 + 0.5 * d.y)) *
                 size;
    };
    auto clip = [&](glm::vec2 p) { return glm::clamp(p, origin, origin + glm::vec2(size)); };
    auto mapLine = [&](const glm::dvec3& a, const glm::dvec3& b, glm::vec4 color) {
      line(clip(toMap(a)), clip(toMap(b)), color);
    };
    // Casters drawn per cascade as dots (cascade 0 on top, smallest).
    for (int c = static_cast<int>(n) - 1; c >= 0; --c) {
      const glm::vec4 tint(csm::cascadeTint(c), 0.9f);
      const float dot = 1.0f + 0.5f * static_cast<float>(c);
      for (std::uint32_t k : culled.visible[static_cast<std::size_t>(c)]) {
        const csm::AabbWs& b = casterBounds_[k];  // clusters, then the dynamic casters
        const glm::vec2 p = toMap(0.5 * (b.minWs + b.maxWs));
        if (p.x < origin.x || p.y < origin.y || p.x > origin.x + size || p.y > origin.y + size) {
          continue;
        }
        quad(p - glm::vec2(dot), p + glm::vec2(dot), tint, solid);
      }
    }
    const glm::dvec3 fwd = camera_.forwardWs(), right = camera_.rightWs(), up = camera_.upWs();
    const double ty = std::tan(0.5 * camera_.fovYRad), tx = ty * camera_.aspect;
    for (std::uint32_t c = 0; c < n; ++c) {
      const csm::Cascade& cs = cascades.cascades[c];
      const glm::vec4 tint(csm::cascadeTint(static_cast<int>(c)), 1.0f);
      // Frustum slice: its far rectangle and the edges back to its near rectangle.
      glm::dvec3 nearC[4], farC[4];
      const double sx[4] = {-1, 1, 1, -1}, sy[4] = {-1, -1, 1, 1};
      for (int k = 0; k < 4; ++k) {
        nearC[k] = cam + cs.splitNearM * (fwd + sx[k] * tx * right + sy[k] * ty * up);
        farC[k] = cam + cs.splitFarM * (fwd + sx[k] * tx * right + sy[k] * ty * up);
      }
      for (int k = 0; k < 4; ++k) {
        mapLine(farC[k], farC[(k + 1) % 4], tint * glm::vec4(1, 1, 1, 0.9f));
        mapLine(nearC[k], farC[k], tint * glm::vec4(1, 1, 1, 0.5f));
      }
      // Bounding sphere.
      const int segs = 48;
      for (int k = 0; k < segs; ++k) {
        const double a0 = 2.0 * 3.14159265358979 * k / segs,
                     a1 = 2.0 * 3.14159265358979 * (k + 1) / segs;
        const glm::dvec3 p0 =
            cs.sphereCenterWs + cs.sphereRadiusM * glm::dvec3(std::cos(a0), 0, std::sin(a0));
        const glm::dvec3 p1 =
            cs.sphereCenterWs + cs.sphereRadiusM * glm::dvec3(std::cos(a1), 0, std::sin(a1));
        mapLine(p0, p1, tint * glm::vec4(1, 1, 1, 0.6f));
      }
      if (cs.empty) continue;
      // Light box: its 12 edges seen from above.
      const glm::dvec3 lr = cascades.lightBasisWs[0], lu = cascades.lightBasisWs[1],
                       lf = cascades.lightBasisWs[2];
      glm::dvec3 corner[8];
      for (int k = 0; k < 8; ++k) {
        corner[k] = cs.boxCenterWs + ((k & 1) ? 1.0 : -1.0) * cs.halfExtentLs.x * lr +
                    ((k & 2) ? 1.0 : -1.0) * cs.halfExtentLs.y * lu +
                    ((k & 4) ? cs.depthFarLs : cs.depthNearLs) * lf;
      }
      const int edges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                                {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
      for (const auto& e : edges)
        mapLine(corner[e[0]], corner[e[1]], tint * glm::vec4(0.8f, 0.8f, 0.8f, 1.0f));
    }
    // The camera: a white cross.
    const glm::vec2 cp = toMap(cam);
    line(cp - glm::vec2(5, 0), cp + glm::vec2(5, 0), glm::vec4(1));
    line(cp - glm::vec2(0, 5), cp + glm::vec2(0, 5), glm::vec4(1));
    quad(origin, origin + glm::vec2(size, 1), glm::vec4(1), solid);
    quad(origin + glm::vec2(0, size - 1), origin + glm::vec2(size), glm::vec4(1), solid);
  }
}

}  // namespace world
