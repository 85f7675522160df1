// CPU-side images and PNG output (stb_image_write).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace engine {

/// An 8-bit RGBA image in CPU memory, rows top to bottom, tightly packed.
struct CpuImage {
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<uint8_t> rgba;  ///< width * height * 4 bytes

  /// The texel at (x, y) as {r, g, b, a}; no bounds check beyond an assert.
  std::array<uint8_t, 4> at(uint32_t x, uint32_t y) const;
};

/// Writes `image` as a PNG file; returns false (and leaves errno-style detail to stb) on failure.
bool writePng(const std::string& path, const CpuImage& image);

}  // namespace engine
