// csm_engine_smoke: renders lit cubes far from the world origin (camera-relative), headless to a
// PNG (--out FILE) or in a window (--window --frames N, exercising resize and minimise), and
// prints the validation message count. Exit codes: 0 success, 1 error or validation messages,
// 3 no Vulkan device.
#include <GLFW/glfw3.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <glm/gtc/matrix_transform.hpp>
#include <memory>
#include <span>
#include <string>

#include <csm_shaders/engine_mesh.frag.spv.h>
#include <csm_shaders/engine_mesh.vert.spv.h>

#include "engine/engine.hpp"

namespace {

struct Options {
  std::string out = "engine_smoke.png";
  bool window = false;
  int frames = 1;
  uint32_t width = 640, height = 360;
};

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--out")
      o.out = value();
    else if (a == "--window")
      o.window = true;
    else if (a == "--frames")
      o.frames = std::stoi(value());
    else if (a == "--width")
      o.width = static_cast<uint32_t>(std::stoul(value()));
    else if (a == "--height")
      o.height = static_cast<uint32_t>(std::stoul(value()));
    else if (a == "--help") {
      std::printf(
          "usage: csm_engine_smoke [--out FILE.png] [--window] [--frames N] "
          "[--width W] [--height H]\n");
      std::exit(0);
    } else {
      throw std::invalid_argument("unknown argument " + a);
    }
  }
  if (o.frames < 1) throw std::invalid_argument("--frames must be >= 1");
  return o;
}

// Push constants of engine_mesh.vert/frag.
struct MeshPush {
  glm::mat4 mvpCr;
  glm::vec4 normalToWs[3];
  glm::vec4 color;
};
static_assert(sizeof(MeshPush) == 128, "matches engine_mesh.vert");

struct Object {
  glm::dvec3 positionWs;
  glm::vec3 scale;
  float spin;  // radians per frame about +Y
  glm::vec4 color;
};

engine::GraphicsPipeline makePipeline(engine::Context& ctx, const engine::RenderTarget& target) {
  auto vs = engine::createShaderModule(ctx.device(), engine_mesh_vert_spv, "smoke.mesh.vert");
  auto fs = engine::createShaderModule(ctx.device(), engine_mesh_frag_spv, "smoke.mesh.frag");
  const VkVertexInputBindingDescription binding = engine::MeshStore::bindingDescription();
  return engine::GraphicsPipelineBuilder()
      .vertexShader(vs)
      .fragmentShader(fs)
      .vertexInput({&binding, 1}, engine::MeshStore::attributeDescriptions())
      .colorFormat(target.colorFormat())
      .depthFormat(target.depthFormat())
      .cullMode(VK_CULL_MODE_BACK_BIT)
      .pushConstants(VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, sizeof(MeshPush))
      .build(ctx, "smoke.mesh.pipeline");
}

/// Draws the objects (spun by `frame` frames) inside the current rendering.
void drawObjects(VkCommandBuffer cmd, const engine::GraphicsPipeline& pipeline,
                 const engine::MeshStore& meshes, const engine::MeshRange& cube,
                 const engine::Camera& camera, std::span<const Object> objects, int frame) {
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.pipeline);
  meshes.bind(cmd);
  const glm::mat4 viewProj = camera.viewProjectionCr();
  for (const Object& o : objects) {
    const glm::mat4 rotation =
        glm::rotate(glm::mat4(1.0f), o.spin * float(frame), glm::vec3(0, 1, 0));
    const glm::mat4 model = glm::translate(glm::mat4(1.0f), camera.toCameraRelative(o.positionWs)) *
                            rotation * glm::scale(glm::mat4(1.0f), o.scale);
    MeshPush push{};
    push.mvpCr = viewProj * model;
    const glm::mat3 normal = glm::transpose(
        glm::inverse(glm::mat3(rotation) * glm::mat3(glm::scale(glm::mat4(1.0f), o.scale))));
    for (int c = 0; c < 3; ++c) push.normalToWs[c] = glm::vec4(normal[c], 0.0f);
    push.color = o.color;
    vkCmdPushConstants(cmd, pipeline.layout,
                       VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push),
                       &push);
    vkCmdDrawIndexed(cmd, cube.indexCount, 1, cube.firstIndex, cube.vertexOffset, 0);
  }
}

int run(const Options& opt) {
  engine::ContextDesc desc;
  desc.appName = "csm_engine_smoke";
  desc.validation = true;
  if (opt.window) engine::WindowTarget::prepareContext(desc);
  engine::Context ctx(desc);
  std::printf("device: %s, validation %s\n", ctx.properties().deviceName,
              ctx.validationEnabled() ? "on" : "off");
  {
    std::unique_ptr<engine::RenderTarget> target;
    engine::WindowTarget* window = nullptr;
    engine::HeadlessTarget* headless = nullptr;
    if (opt.window) {
      auto w = std::make_unique<engine::WindowTarget>(
          ctx, engine::WindowDesc{"csm_engine_smoke", int(opt.width), int(opt.height), true,
                                  VK_FORMAT_D32_SFLOAT});
      window = w.get();
      target = std::move(w);
    } else {
      auto h = std::make_unique<engine::HeadlessTarget>(
          ctx, engine::HeadlessDesc{{opt.width, opt.height}, VK_FORMAT_D32_SFLOAT});
      headless = h.get();
      target = std::move(h);
    }

    engine::MeshStore meshes(ctx, 1024, 4096, "smoke.meshes");
    std::vector<engine::Vertex> vertices;
    std::vector<uint32_t> indices;
    engine::makeCube(vertices, indices);
    const engine::MeshRange cube = meshes.upload(vertices, indices);

    const engine::GraphicsPipeline pipeline = makePipeline(ctx, *target);
    engine::GpuTimer timer(ctx);

    // A scene 10^6 m from the origin: camera-relative rendering keeps it exact in float.
    const glm::dvec3 originWs(1.0e6, 0.0, -2.0e6);
    const Object objects[] = {
        {originWs + glm::dvec3(0, -0.6, 0), {12.0f, 0.2f, 12.0f}, 0.0f, {0.6f, 0.6f, 0.6f, 1}},
        {originWs + glm::dvec3(0, 0.5, 0), {1.0f, 1.0f, 1.0f}, 0.05f, {0.9f, 0.3f, 0.2f, 1}},
        {originWs + glm::dvec3(1.8, 0.2, -1.0), {0.6f, 1.4f, 0.6f}, -0.03f, {0.2f, 0.5f, 0.9f, 1}},
    };
    engine::Camera camera;
    camera.positionWs = originWs + glm::dvec3(3.5, 2.5, 4.5);
    camera.lookAt(originWs + glm::dvec3(0.3, 0.2, 0));

    int rendered = 0, skipped = 0, attempts = 0;
    uint32_t lastSlot = 0;
    while (rendered < opt.frames && attempts++ < opt.frames * 20) {
      if (window) {
        window->pollEvents();
        if (window->shouldClose()) break;
        // Exercise resize and minimise/restore along the way.
        if (rendered == opt.frames / 3)
          glfwSetWindowSize(window->window(), int(opt.width) + 160, int(opt.height) + 90);
        if (rendered == opt.frames / 2 && attempts % 4 == 0) glfwIconifyWindow(window->window());
        if (rendered == opt.frames / 2 && attempts % 4 == 2) glfwRestoreWindow(window->window());
      }
      std::optional<engine::Frame> frame = target->beginFrame();
      if (!frame) {
        ++skipped;
        if (window) glfwWaitEventsTimeout(0.01);
        continue;
      }
      VkCommandBuffer cmd = frame->cmd;
      timer.beginFrame(cmd, frame->slot);
      camera.aspect = double(frame->extent.width) / double(frame->extent.height);
      {
        engine::ScopedLabel label(cmd, "smoke pass");
        timer.begin(cmd, "smoke pass");
        engine::beginRendering(*frame, VkClearColorValue{{0.05f, 0.07f, 0.1f, 1.0f}});
        drawObjects(cmd, pipeline, meshes, cube, camera, objects, rendered);
        vkCmdEndRendering(cmd);
        timer.end(cmd, "smoke pass");
      }
      lastSlot = frame->slot;
      target->endFrame();
      ++rendered;
    }
    target->waitIdle();
    timer.collect(lastSlot);
    std::printf("frames rendered: %d, skipped: %d\n", rendered, skipped);
    if (window) std::printf("swapchain generations: %u\n", window->swapchainGeneration());
    for (const auto& [name, ms] : timer.results())
      std::printf("gpu %s: %.3f ms\n", name.c_str(), ms);
    if (headless) {
      headless->savePng(opt.out);
      std::printf("wrote %s\n", opt.out.c_str());
    }
    if (rendered < opt.frames) throw std::runtime_error("could not render all frames");
  }
  ctx.shutdown();
  const engine::ValidationCounts counts = engine::validationCounts();
  std::printf("validation messages: %llu (%llu warnings, %llu errors)\n",
              static_cast<unsigned long long>(counts.warnings + counts.errors),
              static_cast<unsigned long long>(counts.warnings),
              static_cast<unsigned long long>(counts.errors));
  return counts.warnings + counts.errors == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  return engine::runMain([&] { return run(parse(argc, argv)); });
}
