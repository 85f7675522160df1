// Small Vulkan helpers of the glue, its tools (tools/measure) and the sample world's renderer:
// zero-initialised Vulkan structs with sType set, a descriptor pool, a set from it, and a
// storage/uniform buffer written into a set (the engine's own helpers are private to it).
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>

#include "engine/debug.hpp"
#include "engine/errors.hpp"
#include "engine/pipeline.hpp"

namespace glue::detail {

/// A value-initialised `T` with `sType` set.
template <class T>
T vkStruct(VkStructureType type) {
  T value{};
  value.sType = type;
  return value;
}

/// Points binding `binding` of `set` at the whole of `buffer`.
inline void writeBufferDescriptor(VkDevice dev, VkDescriptorSet set, uint32_t binding,
                                  VkDescriptorType type, VkBuffer buffer) {
  VkDescriptorBufferInfo info{buffer, 0, VK_WHOLE_SIZE};
  auto w = vkStruct<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
  w.dstSet = set;
  w.dstBinding = binding;
  w.descriptorCount = 1;
  w.descriptorType = type;
  w.pBufferInfo = &info;
  vkUpdateDescriptorSets(dev, 1, &w, 0, nullptr);
}

/// A pool for `maxSets` descriptor sets holding `count` descriptors of `type` in all, named
/// `name`.
inline engine::DeviceHandle<VkDescriptorPool> makeDescriptorPool(VkDevice dev,
                                                                 VkDescriptorType type,
                                                                 uint32_t count, const char* name,
                                                                 uint32_t maxSets = 1) {
  VkDescriptorPoolSize size{type, count};
  auto pi = vkStruct<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
  pi.maxSets = maxSets;
  pi.poolSizeCount = 1;
  pi.pPoolSizes = &size;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkCreateDescriptorPool(dev, &pi, nullptr, &pool));
  engine::setDebugName(dev, pool, name);
  return engine::DeviceHandle<VkDescriptorPool>(dev, pool, vkDestroyDescriptorPool);
}

/// One set of `layout` from `pool`, named `name`.
inline VkDescriptorSet allocateDescriptorSet(VkDevice dev, VkDescriptorPool pool,
                                             VkDescriptorSetLayout layout, const char* name) {
  auto ai = vkStruct<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
  ai.descriptorPool = pool;
  ai.descriptorSetCount = 1;
  ai.pSetLayouts = &layout;
  VkDescriptorSet set = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkAllocateDescriptorSets(dev, &ai, &set));
  engine::setDebugName(dev, set, name);
  return set;
}

}  // namespace glue::detail
