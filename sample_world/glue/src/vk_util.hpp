// Internal to the glue: zero-initialised Vulkan structs with sType set, and a storage/uniform
// buffer written into a descriptor set (the engine's own helpers are private to it).
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>

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

}  // namespace glue::detail
