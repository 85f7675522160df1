// A test scene (glue/test_scene.hpp) on the GPU: its meshes in one engine::MeshStore and what the
// shadow view and the lit pass draw of it (target csm_test_scene).
#pragma once

#include <csm/vulkan/shadow_renderer.hpp>
#include <engine/context.hpp>
#include <engine/mesh_store.hpp>

#include <memory>
#include <string>
#include <vector>

#include "glue/lit_pass.hpp"
#include "glue/test_scene.hpp"

namespace glue {

struct GpuScene {
  std::unique_ptr<engine::MeshStore> store;
  /// Per mesh of the scene, in its order.
  std::vector<engine::MeshRange> ranges;
  std::vector<csm::vk::MeshDraw> meshDraws;
  /// Per instance of the scene, in its order (Instance::thin carried over).
  std::vector<csm::vk::CasterInstance> casters;
  std::vector<LitDraw> litDraws;
};

/// Uploads every mesh of `scene` into a new MeshStore named `name` (sized to fit) and lists the
/// instances as casters and lit draws.
GpuScene uploadScene(engine::Context& ctx, const Scene& scene, const std::string& name);

}  // namespace glue
