// libFuzzer harness for the mesh readers: the bytes as a file of one format (CSM_FUZZ_FORMAT:
// "obj", "ply" or "off"), then, when they parse, the checks and scaling of --mesh and the
// OpenMesh build (what a parsed file goes through next). Any crash, sanitizer report, leak,
// timeout or out-of-memory is a finding.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "mesh_ops.hpp"
#include "mesh_parse.hpp"

#ifndef CSM_FUZZ_FORMAT
#error "define CSM_FUZZ_FORMAT"
#endif

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  std::string error;
  const std::optional<world::ParsedMesh> parsed =
      world::parseMeshBytes(bytes, CSM_FUZZ_FORMAT, &error);
  if (!parsed) {
    if (error.empty()) std::abort();  // every refusal says why
    return 0;
  }
  for (const std::uint32_t i : parsed->triangles) {
    if (i >= parsed->vertexCount()) std::abort();  // the reader's promise
  }
  const std::optional<world::MeshData> mesh = world::meshFromParsed(*parsed, 30.0, &error);
  if (!mesh) {
    if (error.empty()) std::abort();
    return 0;
  }
  for (const glm::vec3& p : mesh->positions) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) std::abort();
    if (std::abs(p.x) > 30.01f || std::abs(p.y) > 30.01f || std::abs(p.z) > 30.01f) std::abort();
  }
  for (const std::uint32_t i : mesh->indices) {
    if (i >= mesh->positions.size()) std::abort();
  }
  return 0;
}
