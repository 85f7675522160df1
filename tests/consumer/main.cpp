// A host that shares none of the CSM repo's engine code: its own Vulkan instance, device,
// headless target, meshes and lighting shader, plain Vulkan calls only. It renders a box
// floating over the ground, 10^6 m from the origin, with the module's shadows, and writes a PNG.
//   csm_consumer OUT.png        exit 0 on success, 1 on any error or validation message
#include <vulkan/vulkan.h>

#include <cstdio>
#include <cstring>
#include <glm/gtc/matrix_transform.hpp>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb_image_write.h>

#include "scene.frag.h"
#include "scene.hpp"
#include "scene.vert.h"
#include "shadows_integration.hpp"

#if defined(__SANITIZE_ADDRESS__)
#include <dlfcn.h>
#include <link.h>
// Sanitizer builds only (the asan preset passes its flags here): keeps the Vulkan driver and
// layer libraries mapped after vkDestroyInstance, so that LeakSanitizer's reports at exit name
// them and tools/lsan.supp can match (the engine does the same; this host has no engine).
static int pinVulkanLibrary(dl_phdr_info* info, size_t, void*) {
  const std::string name = info->dlpi_name ? info->dlpi_name : "";
  if (name.find("libvulkan_") != std::string::npos ||
      name.find("libVkLayer_") != std::string::npos) {
    (void)dlopen(info->dlpi_name, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
  }
  return 0;
}
static void pinVulkanLibraries() {
  dl_iterate_phdr(pinVulkanLibrary, nullptr);
}
#else
static void pinVulkanLibraries() {}
#endif

namespace {

void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS)
    throw std::runtime_error(std::string(what) + " failed with " + csm::vk::vkResultName(r));
}

int gValidationMessages = 0;

VKAPI_ATTR VkBool32 VKAPI_CALL onDebugMessage(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                              VkDebugUtilsMessageTypeFlagsEXT,
                                              const VkDebugUtilsMessengerCallbackDataEXT* data,
                                              void*) {
  if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
    ++gValidationMessages;
    std::fprintf(stderr, "validation: %s\n", data->pMessage);
  }
  return VK_FALSE;
}

struct Host {
  VkInstance instance = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
  VkPhysicalDevice gpu = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  std::uint32_t family = 0;
  VkQueue queue = VK_NULL_HANDLE;
  VkPhysicalDeviceMemoryProperties memory{};
  bool validation = false;
};

bool hasLayer(const char* name) {
  std::uint32_t n = 0;
  vkEnumerateInstanceLayerProperties(&n, nullptr);
  std::vector<VkLayerProperties> layers(n);
  vkEnumerateInstanceLayerProperties(&n, layers.data());
  for (const auto& l : layers)
    if (std::strcmp(l.layerName, name) == 0) return true;
  return false;
}

void createDevice(Host& h) {
  const char* layer = "VK_LAYER_KHRONOS_validation";
  h.validation = hasLayer(layer);
  const char* ext = VK_EXT_DEBUG_UTILS_EXTENSION_NAME;
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "csm_consumer";
  app.apiVersion = VK_API_VERSION_1_3;
  VkDebugUtilsMessengerCreateInfoEXT dbg{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
  dbg.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                        VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  dbg.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                    VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                    VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  dbg.pfnUserCallback = onDebugMessage;
  VkInstanceCreateInfo ici{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pNext = h.validation ? &dbg : nullptr;
  ici.pApplicationInfo = &app;
  ici.enabledLayerCount = h.validation ? 1 : 0;
  ici.ppEnabledLayerNames = &layer;
  ici.enabledExtensionCount = h.validation ? 1 : 0;
  ici.ppEnabledExtensionNames = &ext;
  check(vkCreateInstance(&ici, nullptr, &h.instance), "vkCreateInstance");
  if (h.validation) {
    auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(h.instance, "vkCreateDebugUtilsMessengerEXT"));
    check(create(h.instance, &dbg, nullptr, &h.messenger), "vkCreateDebugUtilsMessengerEXT");
  }
  std::uint32_t n = 0;
  vkEnumeratePhysicalDevices(h.instance, &n, nullptr);
  if (n == 0) throw std::runtime_error("no Vulkan device");
  std::vector<VkPhysicalDevice> gpus(n);
  vkEnumeratePhysicalDevices(h.instance, &n, gpus.data());
  h.gpu = gpus[0];
  vkGetPhysicalDeviceMemoryProperties(h.gpu, &h.memory);
  std::uint32_t nf = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(h.gpu, &nf, nullptr);
  std::vector<VkQueueFamilyProperties> families(nf);
  vkGetPhysicalDeviceQueueFamilyProperties(h.gpu, &nf, families.data());
  while (h.family < nf && !(families[h.family].queueFlags & VK_QUEUE_GRAPHICS_BIT)) ++h.family;

  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qci{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = h.family;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  f13.dynamicRendering = VK_TRUE;
  f13.synchronization2 = VK_TRUE;
  VkPhysicalDeviceFeatures2 f2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &f13};
  f2.features.depthClamp = VK_TRUE;
  VkDeviceCreateInfo dci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO, &f2};
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  check(vkCreateDevice(h.gpu, &dci, nullptr, &h.device), "vkCreateDevice");
  pinVulkanLibraries();
  vkGetDeviceQueue(h.device, h.family, 0, &h.queue);
}

std::uint32_t memoryType(const Host& h, std::uint32_t bits, VkMemoryPropertyFlags flags) {
  for (std::uint32_t i = 0; i < h.memory.memoryTypeCount; ++i) {
    if ((bits & (1u << i)) && (h.memory.memoryTypes[i].propertyFlags & flags) == flags) return i;
  }
  throw std::runtime_error("no suitable memory type");
}

struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  void* mapped = nullptr;
};

Buffer createBuffer(const Host& h, VkDeviceSize size, VkBufferUsageFlags usage) {
  Buffer b;
  VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = size;
  bci.usage = usage;
  check(vkCreateBuffer(h.device, &bci, nullptr, &b.buffer), "vkCreateBuffer");
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(h.device, b.buffer, &req);
  VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex =
      memoryType(h, req.memoryTypeBits,
                 VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
  check(vkAllocateMemory(h.device, &mai, nullptr, &b.memory), "vkAllocateMemory");
  check(vkBindBufferMemory(h.device, b.buffer, b.memory, 0), "vkBindBufferMemory");
  check(vkMapMemory(h.device, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped), "vkMapMemory");
  return b;
}

struct Image {
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
};

Image createImage(const Host& h, VkFormat format, VkImageUsageFlags usage,
                  VkImageAspectFlags aspect) {
  Image img;
  VkImageCreateInfo ici{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ici.imageType = VK_IMAGE_TYPE_2D;
  ici.format = format;
  ici.extent = {scene::kWidth, scene::kHeight, 1};
  ici.mipLevels = 1;
  ici.arrayLayers = 1;
  ici.samples = VK_SAMPLE_COUNT_1_BIT;
  ici.usage = usage;
  check(vkCreateImage(h.device, &ici, nullptr, &img.image), "vkCreateImage");
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(h.device, img.image, &req);
  VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = memoryType(h, req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  check(vkAllocateMemory(h.device, &mai, nullptr, &img.memory), "vkAllocateMemory");
  check(vkBindImageMemory(h.device, img.image, img.memory, 0), "vkBindImageMemory");
  VkImageViewCreateInfo vci{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  vci.image = img.image;
  vci.viewType = VK_IMAGE_VIEW_TYPE_2D;
  vci.format = format;
  vci.subresourceRange = {aspect, 0, 1, 0, 1};
  check(vkCreateImageView(h.device, &vci, nullptr, &img.view), "vkCreateImageView");
  return img;
}

void barrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, VkImageLayout from,
             VkImageLayout to, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
             VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess) {
  VkImageMemoryBarrier2 b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
  b.srcStageMask = srcStage;
  b.srcAccessMask = srcAccess;
  b.dstStageMask = dstStage;
  b.dstAccessMask = dstAccess;
  b.oldLayout = from;
  b.newLayout = to;
  b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {aspect, 0, 1, 0, 1};
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.imageMemoryBarrierCount = 1;
  dep.pImageMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cmd, &dep);
}

struct Vertex {
  glm::vec3 position, normal;
};

// An axis-aligned box (24 vertices with face normals) and a ground quad, appended to one mesh
// buffer pair; returns the draw range.
csm::vk::MeshDraw appendBox(std::vector<Vertex>& v, std::vector<std::uint32_t>& idx, glm::vec3 lo,
                            glm::vec3 hi) {
  csm::vk::MeshDraw d;
  d.firstIndex = static_cast<std::uint32_t>(idx.size());
  d.vertexOffset = static_cast<std::int32_t>(v.size());
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      glm::vec3 n(0.0f);
      n[axis] = side ? 1.0f : -1.0f;
      const int u = (axis + 1) % 3, w = (axis + 2) % 3;
      const auto base = static_cast<std::uint32_t>(v.size()) - d.vertexOffset;
      for (int k = 0; k < 4; ++k) {
        glm::vec3 p;
        p[axis] = side ? hi[axis] : lo[axis];
        p[u] = (k == 1 || k == 2) ? hi[u] : lo[u];
        p[w] = (k >= 2) ? hi[w] : lo[w];
        v.push_back({p, n});
      }
      for (std::uint32_t k : {0u, 1u, 2u, 0u, 2u, 3u}) idx.push_back(base + k);
    }
  }
  d.indexCount = static_cast<std::uint32_t>(idx.size()) - d.firstIndex;
  return d;
}

}  // namespace

int main(int argc, char** argv) try {
  if (argc != 2) {
    std::fprintf(stderr, "usage: csm_consumer OUT.png\n");
    return 2;
  }
  Host h;
  createDevice(h);

  // Meshes in local coordinates; each is placed at kOrigin in double precision.
  std::vector<Vertex> vertices;
  std::vector<std::uint32_t> indices;
  const float g = static_cast<float>(scene::kGroundHalfM);
  csm::vk::MeshDraw ground = appendBox(vertices, indices, {-g, -0.5f, -g}, {g, 0.0f, g});
  csm::vk::MeshDraw box =
      appendBox(vertices, indices, glm::vec3(scene::kBoxMin), glm::vec3(scene::kBoxMax));
  Buffer vb = createBuffer(h, vertices.size() * sizeof(Vertex), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT);
  Buffer ib = createBuffer(h, indices.size() * 4, VK_BUFFER_USAGE_INDEX_BUFFER_BIT);
  std::memcpy(vb.mapped, vertices.data(), vertices.size() * sizeof(Vertex));
  std::memcpy(ib.mapped, indices.data(), indices.size() * 4);
  for (csm::vk::MeshDraw* d : {&ground, &box}) {
    d->vertexBuffer = vb.buffer;
    d->indexBuffer = ib.buffer;
  }
  const csm::vk::MeshDraw meshes[2] = {ground, box};
  const csm::AabbWs bounds[2] = {
      {scene::kOrigin + glm::dvec3(-g, -0.5, -g), scene::kOrigin + glm::dvec3(g, 0, g)},
      {scene::kOrigin + scene::kBoxMin, scene::kOrigin + scene::kBoxMax}};
  const csm::AabbWs sceneBounds{scene::kOrigin + glm::dvec3(-g, -0.5, -g),
                                scene::kOrigin + glm::dvec3(g, scene::kBoxMax.y, g)};

  auto shadows = createShadows(h.gpu, h.device, h.family, h.queue, meshes, bounds, scene::kOrigin,
                               sceneBounds);

  // Target images and the lighting pipeline (set 1 = the module's resources).
  Image color = createImage(h, VK_FORMAT_R8G8B8A8_UNORM,
                            VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                            VK_IMAGE_ASPECT_COLOR_BIT);
  Image depth =
      createImage(h, VK_FORMAT_D32_SFLOAT,
                  VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT,
                  VK_IMAGE_ASPECT_DEPTH_BIT);
  Buffer readback =
      createBuffer(h, scene::kWidth * scene::kHeight * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT);

  struct Push {
    glm::mat4 viewProjCr;
    glm::vec4 translationCr;
    glm::vec4 color;
  };
  VkShaderModule modules[2];
  const std::uint32_t* code[2] = {scene_vert_spv, scene_frag_spv};
  const std::size_t sizes[2] = {sizeof scene_vert_spv, sizeof scene_frag_spv};
  for (int i = 0; i < 2; ++i) {
    VkShaderModuleCreateInfo smci{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    smci.codeSize = sizes[i];
    smci.pCode = code[i];
    check(vkCreateShaderModule(h.device, &smci, nullptr, &modules[i]), "vkCreateShaderModule");
  }
  VkDescriptorSetLayout emptyLayout;
  VkDescriptorSetLayoutCreateInfo dslci{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  check(vkCreateDescriptorSetLayout(h.device, &dslci, nullptr, &emptyLayout), "set layout");
  const VkDescriptorSetLayout setLayouts[2] = {emptyLayout, shadows->lightingSetLayout()};
  VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                            sizeof(Push)};
  VkPipelineLayoutCreateInfo plci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  plci.setLayoutCount = 2;
  plci.pSetLayouts = setLayouts;
  plci.pushConstantRangeCount = 1;
  plci.pPushConstantRanges = &range;
  VkPipelineLayout pipelineLayout;
  check(vkCreatePipelineLayout(h.device, &plci, nullptr, &pipelineLayout), "pipeline layout");

  VkPipelineShaderStageCreateInfo stages[2] = {
      {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO},
      {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO}};
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  for (int i = 0; i < 2; ++i) {
    stages[i].module = modules[i];
    stages[i].pName = "main";
  }
  // The filter of the view's settings (kernel, blend, PCSS taps): csm.glsl's constants.
  stages[1].pSpecializationInfo = shadows->lightingSpecializationInfo();
  VkVertexInputBindingDescription binding{0, sizeof(Vertex), VK_VERTEX_INPUT_RATE_VERTEX};
  VkVertexInputAttributeDescription attrs[2] = {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, 0},
                                                {1, 0, VK_FORMAT_R32G32B32_SFLOAT, 12}};
  VkPipelineVertexInputStateCreateInfo vin{
      VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  vin.vertexBindingDescriptionCount = 1;
  vin.pVertexBindingDescriptions = &binding;
  vin.vertexAttributeDescriptionCount = 2;
  vin.pVertexAttributeDescriptions = attrs;
  VkPipelineInputAssemblyStateCreateInfo ia{
      VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  ia.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkViewport viewport{0, 0, float(scene::kWidth), float(scene::kHeight), 0, 1};
  VkRect2D scissor{{0, 0}, {scene::kWidth, scene::kHeight}};
  VkPipelineViewportStateCreateInfo vp{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  vp.viewportCount = 1;
  vp.pViewports = &viewport;
  vp.scissorCount = 1;
  vp.pScissors = &scissor;
  VkPipelineRasterizationStateCreateInfo rs{
      VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  rs.polygonMode = VK_POLYGON_MODE_FILL;
  rs.cullMode = VK_CULL_MODE_NONE;
  rs.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo ms{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineDepthStencilStateCreateInfo ds{
      VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
  ds.depthTestEnable = VK_TRUE;
  ds.depthWriteEnable = VK_TRUE;
  ds.depthCompareOp = VK_COMPARE_OP_LESS;
  VkPipelineColorBlendAttachmentState cba{};
  cba.colorWriteMask = 0xF;
  VkPipelineColorBlendStateCreateInfo cb{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  cb.attachmentCount = 1;
  cb.pAttachments = &cba;
  const VkFormat colorFormat = VK_FORMAT_R8G8B8A8_UNORM;
  VkPipelineRenderingCreateInfo rci{VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO};
  rci.colorAttachmentCount = 1;
  rci.pColorAttachmentFormats = &colorFormat;
  rci.depthAttachmentFormat = VK_FORMAT_D32_SFLOAT;
  VkGraphicsPipelineCreateInfo gpci{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO, &rci};
  gpci.stageCount = 2;
  gpci.pStages = stages;
  gpci.pVertexInputState = &vin;
  gpci.pInputAssemblyState = &ia;
  gpci.pViewportState = &vp;
  gpci.pRasterizationState = &rs;
  gpci.pMultisampleState = &ms;
  gpci.pDepthStencilState = &ds;
  gpci.pColorBlendState = &cb;
  gpci.layout = pipelineLayout;
  VkPipeline pipeline;
  check(vkCreateGraphicsPipelines(h.device, VK_NULL_HANDLE, 1, &gpci, nullptr, &pipeline),
        "pipeline");

  // The camera: double-precision position, camera-relative view.
  csm::Camera camera;
  camera.positionWs = scene::kOrigin + scene::kEye;
  const glm::dmat4 look =
      glm::lookAt(glm::dvec3(0.0), scene::kTarget - scene::kEye, glm::dvec3(0, 1, 0));
  camera.orientationWs = glm::quat_cast(glm::transpose(glm::dmat3(look)));
  camera.fovYRad = glm::radians(scene::kFovYDeg);
  camera.aspect = double(scene::kWidth) / scene::kHeight;
  camera.nearM = scene::kNearM;
  camera.farM = scene::kFarM;
  glm::mat4 proj = glm::perspectiveRH_ZO(float(camera.fovYRad), float(camera.aspect),
                                         float(camera.nearM), float(camera.farM));
  proj[1][1] *= -1.0f;  // Vulkan's y points down
  const glm::mat4 viewProjCr = proj * glm::mat4(glm::mat3(look));
  const csm::DirectionalLight light{scene::kLightDir};

  VkCommandPool pool;
  VkCommandPoolCreateInfo cpci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  cpci.queueFamilyIndex = h.family;
  check(vkCreateCommandPool(h.device, &cpci, nullptr, &pool), "command pool");
  VkCommandBuffer cmd;
  VkCommandBufferAllocateInfo cbai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  cbai.commandPool = pool;
  cbai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  cbai.commandBufferCount = 1;
  check(vkAllocateCommandBuffers(h.device, &cbai, &cmd), "command buffer");
  VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  VkFence fence;
  VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  check(vkCreateFence(h.device, &fci, nullptr, &fence), "fence");

  // A few frames of a still camera: the view's receiver fit reads frame N's depth buffer when it
  // records frame N + framesInFlight (2), and the frame after that fits the splits to it; the
  // boxes fit once the bounds were taken with fitted splits (frame 3's, in frame 6).
  constexpr int kFrames = 8;
  for (int frame = 0; frame < kFrames; ++frame) {
    check(vkResetCommandPool(h.device, pool, 0), "reset pool");
    check(vkBeginCommandBuffer(cmd, &begin), "begin");

    // A moving caster: the box slides in, by handle, and stops at the checked place.
    const glm::dvec3 at = scene::kOrigin + glm::dvec3(0.5 * (kFrames - 1 - frame), 0.0, 0.0);
    const csm::AabbWs boxWs{at + scene::kBoxMin, at + scene::kBoxMax};
    if (csm::vk::Status s = shadows->updateCaster(shadows->casterHandle(1), {1, at}, boxWs); !s)
      throw std::runtime_error("csm: " + s.message());
    if (csm::vk::Status s = shadows->record(cmd, camera, light); !s)
      throw std::runtime_error("csm: " + s.message());

    barrier(cmd, color.image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
            VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_NONE, 0,
            VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
            VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
    barrier(
        cmd, depth.image, VK_IMAGE_ASPECT_DEPTH_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
        VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_NONE, 0,
        VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
        VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT |
            VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT);
    VkRenderingAttachmentInfo ca{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    ca.imageView = color.view;
    ca.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    ca.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    ca.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    ca.clearValue.color = {{0.4f, 0.6f, 0.9f, 1.0f}};
    VkRenderingAttachmentInfo da{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    da.imageView = depth.view;
    da.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    da.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    da.storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    da.clearValue.depthStencil = {1.0f, 0};
    VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
    ri.renderArea = scissor;
    ri.layerCount = 1;
    ri.colorAttachmentCount = 1;
    ri.pColorAttachments = &ca;
    ri.pDepthAttachment = &da;
    vkCmdBeginRendering(cmd, &ri);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
    VkDescriptorSet set = shadows->lightingSet();
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelineLayout, 1, 1, &set, 0,
                            nullptr);
    const VkDeviceSize zero = 0;
    vkCmdBindVertexBuffers(cmd, 0, 1, &vb.buffer, &zero);
    vkCmdBindIndexBuffer(cmd, ib.buffer, 0, VK_INDEX_TYPE_UINT32);
    for (const auto& [mesh, rgb, posWs] :
         {std::tuple{ground, glm::vec3(0.8f, 0.8f, 0.75f), scene::kOrigin},
          std::tuple{box, glm::vec3(0.8f, 0.3f, 0.2f), at}}) {
      const Push push{viewProjCr, glm::vec4(glm::vec3(posWs - camera.positionWs), 0.0f),
                      glm::vec4(rgb, 1.0f)};
      vkCmdPushConstants(cmd, pipelineLayout, range.stageFlags, 0, sizeof push, &push);
      vkCmdDrawIndexed(cmd, mesh.indexCount, 1, mesh.firstIndex, mesh.vertexOffset, 0);
    }
    vkCmdEndRendering(cmd);
    // The receiver fit: the depth buffer, made readable by compute, and the projection it was
    // drawn with.
    barrier(cmd, depth.image, VK_IMAGE_ASPECT_DEPTH_BIT, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
            VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
            VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
            VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
    const csm::vk::ReceiverDepthInput depthInput{
        depth.view, VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL, {scene::kWidth, scene::kHeight}, proj};
    if (csm::vk::Status s = shadows->recordReceiverDepth(cmd, depthInput); !s)
      throw std::runtime_error("csm: " + s.message());
    barrier(cmd, color.image, VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
            VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
            VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
            VK_ACCESS_2_TRANSFER_READ_BIT);
    VkBufferImageCopy copy{};
    copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    copy.imageExtent = {scene::kWidth, scene::kHeight, 1};
    vkCmdCopyImageToBuffer(cmd, color.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback.buffer,
                           1, &copy);
    VkBufferMemoryBarrier2 hostRead{VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2};
    hostRead.srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
    hostRead.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
    hostRead.dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT;
    hostRead.dstAccessMask = VK_ACCESS_2_HOST_READ_BIT;
    hostRead.srcQueueFamilyIndex = hostRead.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    hostRead.buffer = readback.buffer;
    hostRead.size = VK_WHOLE_SIZE;
    VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
    dep.bufferMemoryBarrierCount = 1;
    dep.pBufferMemoryBarriers = &hostRead;
    vkCmdPipelineBarrier2(cmd, &dep);
    check(vkEndCommandBuffer(cmd), "end");

    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd;
    check(vkQueueSubmit(h.queue, 1, &si, fence), "submit");
    check(vkWaitForFences(h.device, 1, &fence, VK_TRUE, UINT64_MAX), "wait");
    check(vkResetFences(h.device, 1, &fence), "reset fence");
  }
  // The last frame's cascades fit the receivers: the first split is at the nearest ground the
  // camera sees, not at its near plane.
  const csm::CascadeFrame& fitted = shadows->frame();
  std::printf("csm_consumer: first split %.2f m, %s\n", fitted.splitsM[0],
              fitted.cascades[0].receiverFit ? "boxes fitted to the receivers" : "not fitted");
  if (fitted.splitsM[0] <= scene::kNearM || !fitted.cascades[0].receiverFit)
    throw std::runtime_error("the receiver fit did not reach the last frame");
  if (!stbi_write_png(argv[1], scene::kWidth, scene::kHeight, 4, readback.mapped,
                      scene::kWidth * 4)) {
    throw std::runtime_error(std::string("cannot write ") + argv[1]);
  }

  // Tear down everything (validation reports leaks at device destruction).
  vkDestroyFence(h.device, fence, nullptr);
  vkDestroyCommandPool(h.device, pool, nullptr);
  vkDestroyPipeline(h.device, pipeline, nullptr);
  vkDestroyPipelineLayout(h.device, pipelineLayout, nullptr);
  vkDestroyDescriptorSetLayout(h.device, emptyLayout, nullptr);
  for (VkShaderModule m : modules) vkDestroyShaderModule(h.device, m, nullptr);
  shadows.reset();
  for (Image* img : {&color, &depth}) {
    vkDestroyImageView(h.device, img->view, nullptr);
    vkDestroyImage(h.device, img->image, nullptr);
    vkFreeMemory(h.device, img->memory, nullptr);
  }
  for (Buffer* b : {&vb, &ib, &readback}) {
    vkDestroyBuffer(h.device, b->buffer, nullptr);
    vkFreeMemory(h.device, b->memory, nullptr);
  }
  vkDestroyDevice(h.device, nullptr);
  if (h.messenger) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(h.instance, "vkDestroyDebugUtilsMessengerEXT"));
    destroy(h.instance, h.messenger, nullptr);
  }
  vkDestroyInstance(h.instance, nullptr);
  std::printf("csm_consumer: wrote %s (%d validation messages%s)\n", argv[1], gValidationMessages,
              h.validation ? "" : ", validation layer not installed");
  return gValidationMessages == 0 ? 0 : 1;
} catch (const std::exception& e) {
  std::fprintf(stderr, "csm_consumer: %s\n", e.what());
  return 1;
}
