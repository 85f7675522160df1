// The measurement scene is the shared test scene (glue/test_scene.hpp, target csm_test_scene),
// named here as the measurement code has always named it.
#pragma once

#include <glue/test_scene.hpp>

namespace csm_measure {

using glue::Instance;
using glue::InstanceKind;
using glue::makeCubeMesh;
using glue::makeGroundMesh;
using glue::makeSphereMesh;
using glue::MeshData;
using glue::Receiver;
using glue::Scene;
using glue::terrainHeight;
using glue::TestSceneDesc;

}  // namespace csm_measure
