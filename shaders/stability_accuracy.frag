#version 450
// The accuracy pass (stability_accuracy.glsl) with every filter at level 0: the prefiltered
// filters' moments are read at the receiver's texel, whatever the pixel's footprint.
#extension GL_GOOGLE_include_directive : require

#include "stability_accuracy.glsl"
