// Constants of the GPU interface that C++ (csm/gpu_layout.hpp) and GLSL (csm.glsl) share, beside
// csm/shared_constants.h. Only preprocessor definitions: GLSL and C++ both parse it.
#ifndef CSM_GPU_SHARED_H
#define CSM_GPU_SHARED_H

// Non-comparison view of the shadow map (sampler2DArray, nearest): the debug outputs that show
// the stored depth need the raw value, which a comparison sampler cannot return.
#define CSM_BINDING_SHADOW_DEPTH 2

// Debug outputs of csm.glsl, chosen at run time through CsmUniforms.debugMode.
#define CSM_DEBUG_NONE 0         // normal shading
#define CSM_DEBUG_NORMAL 1       // world normal * 0.5 + 0.5
#define CSM_DEBUG_SHADOW 2       // shadow factor as grey (1 lit, 0 shadowed)
#define CSM_DEBUG_LIGHT_COORDS 3 // shadow-map uv in red/green, receiver depth in blue
#define CSM_DEBUG_SAMPLED_DEPTH 4 // stored depth at the receiver's texel as grey
#define CSM_DEBUG_DEPTH_DIFF 5   // red: receiver behind the stored depth (shadow), green: lit
#define CSM_DEBUG_CASCADE 6      // flat tint of the selected cascade (CSM_TINT_i), black outside
#define CSM_DEBUG_TILES 7        // receiver-marked tiles: green sampled in its own cascade(s), red
                                 // fell back to a coarser one, black outside the cascades
#define CSM_DEBUG_COUNT 8

// Cascade tints of CSM_DEBUG_CASCADE, as "r, g, b" (write vec3(CSM_TINT_0) on either side).
// Far apart in RGB so that a test can tell them apart after 8-bit quantisation.
#define CSM_TINT_0 1.0, 0.0, 0.0
#define CSM_TINT_1 0.0, 1.0, 0.0
#define CSM_TINT_2 0.0, 0.0, 1.0
#define CSM_TINT_3 1.0, 1.0, 0.0
#define CSM_TINT_4 1.0, 0.0, 1.0
#define CSM_TINT_5 0.0, 1.0, 1.0
#define CSM_TINT_6 1.0, 0.5, 0.0
#define CSM_TINT_7 0.5, 0.0, 1.0
// One tint per cascade: the tables on both sides have this size.
#define CSM_TINT_COUNT 8
#if CSM_TINT_COUNT != CSM_MAX_CASCADES
#error "csm/gpu_shared.h: one CSM_TINT_i per cascade (CSM_MAX_CASCADES)"
#endif

// Period of the world-anchored texel index in CsmUniforms cascades[i].worldTexelOrigin: a power of
// two (the index stays exact in float and wraps cleanly) far above any kernel's reach.
#define CSM_WORLD_TEXEL_PERIOD 4096.0

// Depth-pass push constants, the same size in both render modes: per-layer (csm_depth.vert) the
// model -> shadow clip matrix (64 bytes) then the cascade index; layered (csm_depth_layered.vert)
// the model -> camera-relative world matrix then the mask of cascades to replicate into.
#define CSM_DEPTH_PUSH_SIZE 68
// After them, for the thin casters' geometry stage only (csm_depth_thin.geom): the widening in
// texels each side for each layer the draw writes (per-layer pass: [0]; layered: [cascade]).
#define CSM_THIN_PUSH_OFFSET 68
#define CSM_THIN_PUSH_SIZE (4 * CSM_MAX_CASCADES)

#endif
