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
#define CSM_BINDING_MOMENTS 3     // sampler2DArray: the prefiltered filters' moments (trilinear)

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
// The percentage-closer kernels above compare depths; CSM_KERNEL_COUNT of them.
#define CSM_KERNEL_COUNT 6
// Prefiltered filters: the map's depths become moments (a second 2D-array image, one layer per
// cascade, blurred and mip-mapped by csm_moments.comp after each shadow pass), which filter like
// colours; one trilinear tap per cascade then bounds the lit fraction from the filtered moments.
#define CSM_KERNEL_VSM 6   // variance: (z, z^2), Chebyshev's upper bound
#define CSM_KERNEL_EVSM 7  // exponential variance: (e^(c+ w), e^(2 c+ w), -e^(-c- w), e^(-2 c- w))
#define CSM_KERNEL_MSM 8   // four power moments of 2z - 1, Hamburger reconstruction
// Every filter, percentage-closer and prefiltered.
#define CSM_FILTER_COUNT 9
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
// The prefiltered filters read one bilinear tap of the blurred moments: one texel, plus the blur.
#define CSM_KERNEL_RADIUS_MOMENTS 1.0

// Prefiltered filters: the moment blur's largest radius in texels of a cascade (its width is set
// in metres, ShadowSettings::momentBlurM, so it spans more texels in finer cascades; beyond this
// the blur is cut to keep the resolve's cost bounded), and the largest EVSM exponent: e^(2 c)
// must stay finite in a 32-bit float (e^88.7 overflows), with the blur's sums, so c <= 42.
#define CSM_MOMENT_MAX_BLUR_TEXELS 12
#define CSM_EVSM_MAX_EXPONENT 42.0
// VSM's least variance (units of stored depth squared): 32-bit moments of depths in [0, 1] lose
// about 1e-7 of variance to rounding (E[z^2] - E[z]^2), and a cascade's depth window moves with
// the camera, so that noise changes from frame to frame. Measured (prefiltered_test, stabilised
// receivers): without this floor a receiver changed by up to 0.1 between frames; 1e-5 bounds the
// change by noise / (4 floor) = 0.0025, under 1/255. EVSM's warps and MSM's centred moments do not
// need it.
#define CSM_VSM_MIN_VARIANCE 1e-5
// Local size of csm_moments.comp, and the texels of its column each invocation of the blur
// (pass 0) writes: a workgroup blurs CSM_MOMENT_GROUP_X x (CSM_MOMENT_GROUP_Y x CSM_MOMENT_ROWS)
// texels, through (8 + 24) x (32 + 24) depths and rows in shared memory at the largest blur:
// 14.4 KB, within the 16 KB every Vulkan device has. The mips use one texel an invocation.
#define CSM_MOMENT_GROUP_X 8
#define CSM_MOMENT_GROUP_Y 8
#define CSM_MOMENT_ROWS 4

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

// Receiver-marked tiles (csm::ReceiverTileMarks, csm_depth_range.comp): a cascade's layer is
// divided into CSM_TILES_PER_SIDE^2 tiles of resolution / CSM_TILES_PER_SIDE texels on the
// world-anchored texel grid; a box of `resolution` texels that does not start on a tile boundary
// spans one tile more per side, so the marks of a cascade are a CSM_TILE_GRID_SIDE^2 bit grid in
// CSM_TILE_WORDS 32-bit words.
#define CSM_TILES_PER_SIDE 16
#define CSM_TILE_GRID_SIDE 17
#define CSM_TILE_WORDS 10

// MSM's 64-bit moments (RGBA16_UNORM): Peters and Klein's optimised quantisation (2015, sec. 4.3),
// q = E b(z) + e for b(z) = (z, z^2, z^3, z^4), composed here with z = (w + 1) / 2 so that it
// takes the centred moments (w, w^2, w^3, w^4) csm_moments.comp computes: q = E' m + e'. q lies
// in [0, 1] for every depth; the map is affine, so blurring, mip-mapping and bilinear filtering
// the quantised moments and then decoding, m = D (q - e') (D the inverse of E'), gives the
// filtered moments. Columns of E' and D (GLSL mat4 and glm::mat4 order), then e'. Derived in
// double from the paper's matrix (test Moments.MsmQuantisationIsThePapersComposedWithTheCentring).
#define CSM_MSM_QUANTIZE_MATRIX                                                           \
  -0.789175476275, -0.914491099875, 0.941599084387, -3.28749916179e-09, -2.8910207496,    \
      2.63455252372, 0.533803255875, 0.548499052625, 1.27119752847, 1.41327106497,        \
      -0.494880329737, 3.43750006238e-09, 2.46064546334, -2.21030645356, -0.415896817144, \
      -1.49830030103
#define CSM_MSM_QUANTIZE_OFFSET 0.948353223264, 0.0745338949375, 0.328812315919, 0.949801248556
#define CSM_MSM_DEQUANTIZE_MATRIX                                                         \
  0.44554882918, -0.271225953896, 0.638622530664, -0.0992906281379, 0.154394572156,       \
      0.249062626302, 0.485790130087, 0.0911770595247, 1.58539732731, 0.0145716805194,    \
      1.00704854759, 0.00533441206965, 0.0638835109228, -0.816896291054, 0.0526264911991, \
      -0.966473036659

#endif
