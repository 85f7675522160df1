// Upload and readback round trips through staging buffers, and the shared mesh buffers.
#include <cstring>

#include "engine_gpu_test.hpp"

namespace {

using engine_test::GpuTest;

std::vector<std::byte> pattern(size_t n, uint32_t seed) {
  std::vector<std::byte> v(n);
  uint32_t x = seed;
  for (auto& b : v) {
    x = x * 1664525u + 1013904223u;
    b = std::byte(x >> 24);
  }
  return v;
}

TEST_F(GpuTest, BufferUploadReadbackRoundTrip) {
  const VkDeviceSize size = (1u << 20) + 13;
  engine::Buffer buffer(ctx(), size,
                        VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                            VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                        engine::MemoryUsage::DeviceLocal, "test.roundtrip_buffer");
  const std::vector<std::byte> data = pattern(size - 256, 7);
  engine::uploadBuffer(ctx(), buffer, 256, data);
  EXPECT_EQ(engine::readbackBuffer(ctx(), buffer, 256, data.size()), data);
  // A second upload over part of it, then both parts read back.
  const std::vector<std::byte> patch = pattern(1000, 99);
  engine::uploadBuffer(ctx(), buffer, 4096, patch);
  const std::vector<std::byte> back = engine::readbackBuffer(ctx(), buffer, 4096, patch.size());
  EXPECT_EQ(back, patch);
  EXPECT_THROW(engine::uploadBuffer(ctx(), buffer, size - 10, patch), std::out_of_range);
}

TEST_F(GpuTest, HostVisibleBufferIsPersistentlyMapped) {
  engine::Buffer uniforms(ctx(), 256, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                          engine::MemoryUsage::Upload, "test.uniforms");
  ASSERT_NE(uniforms.mapped(), nullptr);
  std::memset(uniforms.mapped(), 0xAB, 256);
  engine::Buffer moved = std::move(uniforms);
  EXPECT_FALSE(uniforms);
  EXPECT_EQ(static_cast<unsigned char*>(moved.mapped())[255], 0xAB);
}

TEST_F(GpuTest, ImageArrayUploadReadbackRoundTrip) {
  engine::ImageDesc desc;
  desc.format = VK_FORMAT_R8G8B8A8_UNORM;
  desc.extent = {37, 19};  // odd sizes: no accidental row padding
  desc.layers = 3;
  desc.usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT |
               VK_IMAGE_USAGE_SAMPLED_BIT;
  desc.viewType = VK_IMAGE_VIEW_TYPE_2D_ARRAY;
  engine::Image image(ctx(), desc, "test.roundtrip_image");
  const size_t layerBytes = 37 * 19 * 4;
  const std::vector<std::byte> texels = pattern(layerBytes * 3, 3);
  engine::uploadImage(ctx(), image, texels, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  for (uint32_t layer = 0; layer < 3; ++layer) {
    const std::vector<std::byte> back =
        engine::readbackImage(ctx(), image, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, layer);
    ASSERT_EQ(back.size(), layerBytes);
    EXPECT_TRUE(std::equal(back.begin(), back.end(), texels.begin() + layer * layerBytes))
        << "layer " << layer;
  }
  // A single-layer view of layer 2, as a shadow renderer would make per cascade.
  VkImageView view = image.createView(VK_IMAGE_VIEW_TYPE_2D, 2, 1, "test.layer2");
  EXPECT_NE(view, VK_NULL_HANDLE);
  vkDestroyImageView(ctx().device(), view, nullptr);
}

TEST_F(GpuTest, DepthImageUploadReadback) {
  engine::ImageDesc desc;
  desc.format = VK_FORMAT_D32_SFLOAT;
  desc.extent = {8, 4};
  desc.usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT |
               VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT;
  engine::Image depth(ctx(), desc, "test.depth");
  EXPECT_EQ(depth.aspect(), VkImageAspectFlags(VK_IMAGE_ASPECT_DEPTH_BIT));
  std::vector<float> values(32);
  for (size_t i = 0; i < values.size(); ++i) values[i] = float(i) / 31.0f;
  engine::uploadImage(ctx(), depth, engine::asBytes(values),
                      VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
  const std::vector<std::byte> back =
      engine::readbackImage(ctx(), depth, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
  ASSERT_EQ(back.size(), 32 * sizeof(float));
  EXPECT_EQ(std::memcmp(back.data(), values.data(), back.size()), 0);
}

TEST_F(GpuTest, MeshStorePacksMeshesIntoSharedBuffers) {
  engine::MeshStore store(ctx(), 100, 200, "test.meshes");
  std::vector<engine::Vertex> vertices;
  std::vector<uint32_t> indices;
  engine::makeCube(vertices, indices);
  ASSERT_EQ(vertices.size(), 24u);
  ASSERT_EQ(indices.size(), 36u);
  const engine::MeshRange a = store.upload(vertices, indices);
  const std::vector<engine::Vertex> tri = {
      {{0, 0, 0}, {0, 0, 1}}, {{1, 0, 0}, {0, 0, 1}}, {{0, 1, 0}, {0, 0, 1}}};
  const std::vector<uint32_t> triIndices = {0, 1, 2};
  const engine::MeshRange b = store.upload(tri, triIndices);
  EXPECT_EQ(a.firstIndex, 0u);
  EXPECT_EQ(a.vertexOffset, 0);
  EXPECT_EQ(a.indexCount, 36u);
  EXPECT_EQ(b.firstIndex, 36u);
  EXPECT_EQ(b.vertexOffset, 24);
  EXPECT_EQ(b.indexCount, 3u);
  EXPECT_EQ(store.vertexCount(), 27u);

  // Indices stay mesh-relative (vertexOffset does the rebasing) and are checked.
  const std::vector<uint32_t> badIndices = {0, 1, 3};
  EXPECT_THROW(store.upload(tri, badIndices), std::invalid_argument);
  EXPECT_THROW(store.upload(std::vector<engine::Vertex>(80), {}), std::length_error);

  // Every cube face normal is a unit axis and its 4 vertices lie on that face.
  for (size_t i = 0; i < vertices.size(); ++i) {
    const glm::vec3 n = vertices[i].normal;
    EXPECT_FLOAT_EQ(glm::dot(vertices[i].position, n), 0.5f);
  }
}

}  // namespace
