// engine::Camera <-> csm::Camera: the same camera (position, orientation, field of view, aspect,
// near and far planes) as each side describes it. The one place the two are converted.
#pragma once

#include "csm/types.hpp"
#include "engine/camera.hpp"

namespace glue {

/// The module's camera for an engine camera (every field copied, nothing rounded).
[[nodiscard]] csm::Camera toCsmCamera(const engine::Camera& camera);

/// The engine camera that renders what a csm::Camera describes.
[[nodiscard]] engine::Camera toEngineCamera(const csm::Camera& camera);

}  // namespace glue
