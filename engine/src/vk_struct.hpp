// Internal: zero-initialised Vulkan structs with sType (and pNext) set, so -Wextra's
// missing-field-initializers stays quiet without listing every member.
#pragma once

#include <vulkan/vulkan.h>

namespace engine::detail {

/// A value-initialised `T` with `sType` and `pNext` set.
template <class T>
T vkStruct(VkStructureType type, void* next = nullptr) {
  T value{};
  value.sType = type;
  value.pNext = next;
  return value;
}

}  // namespace engine::detail
