// The one translation unit that holds stb_image_write's implementation.
#include "engine/image_io.hpp"

#include <cassert>

#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#endif
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#include <stb_image_write.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

namespace engine {

std::array<uint8_t, 4> CpuImage::at(uint32_t x, uint32_t y) const {
  assert(x < width && y < height);
  const size_t i = (size_t(y) * width + x) * 4;
  return {rgba[i], rgba[i + 1], rgba[i + 2], rgba[i + 3]};
}

bool writePng(const std::string& path, const CpuImage& image) {
  if (image.width == 0 || image.height == 0 ||
      image.rgba.size() != size_t(image.width) * image.height * 4)
    return false;
  return stbi_write_png(path.c_str(), static_cast<int>(image.width), static_cast<int>(image.height),
                        4, image.rgba.data(), static_cast<int>(image.width * 4)) != 0;
}

}  // namespace engine
