#version 450
// The accuracy pass (stability_accuracy.glsl) as the sample world's lit pass samples: the
// prefiltered filters read the mip (and, where the sampler allows, the anisotropic footprint) of
// the pixel's footprint on the moment map.
#extension GL_GOOGLE_include_directive : require

#define CSM_IMPLICIT_LOD
#include "stability_accuracy.glsl"
