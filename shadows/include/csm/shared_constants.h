// Constants shared by C++ and GLSL: both sides include this file, so they cannot disagree.
// Only preprocessor definitions: GLSL and C++ both parse it. Each value says why it is what it is.
#ifndef CSM_SHARED_CONSTANTS_H
#define CSM_SHARED_CONSTANTS_H

// Most cascades a view may have: 8 covers 1e-3 m .. 1e5 m at a usable texel density, and keeps
// the uniform block (8 x mat4 + params) well under the 16 KiB minimum maxUniformBufferRange.
#define CSM_MAX_CASCADES 8

// The module's lighting resources. A host picks the descriptor set (CSM_SET before including
// csm.glsl; CSM_DEFAULT_SET is a suggestion); the bindings are fixed: the renderer's
// lightingSetLayout() and writeLightingSet() are built from these same values, so a shader that
// used others would not match the set it is given.
#define CSM_DEFAULT_SET 1
#define CSM_BINDING_UNIFORMS 0    // CsmUniforms block
#define CSM_BINDING_SHADOW_MAP 1  // sampler2DArrayShadow (comparison sampler + 2D-array view)

// PCF kernels (specialisation constant CSM_SPEC_KERNEL). Tent kernels are built from bilinear
// comparison taps, so an NxN tent costs ((N+1)/2)^2 taps instead of N^2.
#define CSM_KERNEL_1TAP 0       // the sampler's own 2x2 bilinear comparison
#define CSM_KERNEL_TENT3 1      // 3x3 tent, 4 taps
#define CSM_KERNEL_TENT5 2      // 5x5 tent, 9 taps
#define CSM_KERNEL_TENT7 3      // 7x7 tent, 16 taps
#define CSM_KERNEL_POISSON16 4  // 16-tap Poisson disk, rotated per pixel
// Percentage-closer soft shadows: blocker search over the raw depth, penumbra from the light's
// angular diameter by similar triangles (in metres, the same in every cascade), then a disk of
// comparison taps that wide. Taps: CSM_SPEC_PCSS_TAPS.
#define CSM_KERNEL_PCSS 5
#define CSM_KERNEL_COUNT 6
// How far (texels of the kernel's own cascade) each kernel reads from its centre: the texels
// whose comparison result carries any weight. Each bilinear comparison tap blends the 2x2 texels
// about it, so a kernel reads one texel beyond its taps' centres: a single tap reads 1; the
// optimised tents ((N+1)/2 taps per axis) reach (N+1)/2 (2, 3, 4: a 3x3 tent's outer row still
// weighs 1/40 at 1.9 texels); the Poisson disk's taps lie within 2 texels (x its scale), plus one.
// With CsmCascadeGpu::kernelScale s the taps spread s times wider: reach 1 + (radius - 1) s.
// csmKernelRadius() (GLSL) and csm::kernelRadiusTexels() (C++) both return these (blend-band and
// edge tests use them). The bias no longer scales with them: every tap compares with the
// receiver's plane at the tap, and the normal offset covers one bilinear tap (csmShadowCoord).
#define CSM_KERNEL_RADIUS_1TAP 1.0
#define CSM_KERNEL_RADIUS_TENT3 2.0
#define CSM_KERNEL_RADIUS_TENT5 3.0
#define CSM_KERNEL_RADIUS_TENT7 4.0
#define CSM_KERNEL_RADIUS_POISSON16 3.0
#define CSM_KERNEL_RADIUS_PCSS 1.25

// Specialisation constant ids used by csm.glsl.
#define CSM_SPEC_KERNEL 0
#define CSM_SPEC_BLEND 1  // 0: hard switch at the split, 1: blend across the band
#define CSM_SPEC_DEBUG 2  // reserved for compile-time removal of debug outputs
#define CSM_SPEC_PCSS_TAPS 3  // PCSS: gathers of the blocker search and comparison taps of the filter

// PCSS tap count when the pipeline does not specialise it: 16 gathers (64 texels) to find the
// blockers and 16 bilinear comparison taps to filter; enough for penumbrae of ~10 texels.
#define CSM_PCSS_DEFAULT_TAPS 16
// Most PCSS taps a pipeline may ask for (the loops are bounded by it).
#define CSM_PCSS_MAX_TAPS 64

// Bins of the receiver view-depth histogram the depth-range reduction builds
// (csm_depth_range.comp, csm::ReceiverDepthHistogram), log-spaced between a near and a far depth:
// 256 over 0.5 .. 1500 m is 22 bins per octave (3% of depth per bin), finer than the ladder's
// 8 rungs per octave the splits are placed on; the shader reduces a 16x16 tile, one bin each.
#define CSM_DEPTH_HISTOGRAM_BINS 256

#endif
