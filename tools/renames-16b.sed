# Issue 16 (16b), step 5: the csm uniform block's fields and the depth pass's push constants
# named for what they hold. One mechanical rename: std140 layout, sizes and offsets unchanged
# (a vec4 read by position became the named scalars/vec2s it packed; gpu_layout.cpp pins them).
#
# Replay on a branch (GNU sed, extended regex), then the depth shaders' push constants:
#   git grep -lE 'splitTexel|depthInfo|wrapInfo|biasParams|softParams|\b(csmU|u|uniforms\(\)|uniforms_)\.(params|counts|cameraForward)|CsmUniforms, (params|counts|cameraForward)' \
#     -- '*.cpp' '*.hpp' '*.h' '*.glsl' '*.comp' '*.vert' '*.frag' | xargs sed -i -E -f tools/renames-16b.sed
#   sed -i -E -f tools/renames-16b-depth-push.sed shadows/shaders/csm_depth*.vert
# The block's names are only renamed behind csm's own prefixes (csmU., u., uniforms()., uniforms_.),
# so the engine's blocks (`frame.params` in shaders/lit.frag, `gpu.params` in lit_pass.cpp) stay.
# Left for the compiler to point at (fix by hand): a whole old vec4 read or written at once
# (`vec4 st = csmU.cascades[i].splitTexel; ... st.z`, `u.params = glm::vec4(...)`), and the
# declarations (CsmCascade/CsmUniformBlock in csm.glsl, CsmCascadeGpu/CsmUniforms in
# gpu_layout.hpp): take those from this branch.
#
# Per cascade (CsmCascadeGpu / CsmCascade):
s/\bsplitTexel\.x\b/splitNearM/g
s/\bsplitTexel\.y\b/splitFarM/g
s/\bsplitTexel\.z\b/texelSizeM/g
s/\bsplitTexel\.w\b/kernelScale/g
s/\bdepthInfo\.x\b/blendStartM/g
s/\bdepthInfo\.y\b/depthRangeM/g
s/\bdepthInfo\.zw\b/worldTexelOrigin/g
s/\bdepthInfo\.z\b/worldTexelOrigin.x/g
s/\bdepthInfo\.w\b/worldTexelOrigin.y/g
s/\bwrapInfo\.xy\b/wrapOffset/g
s/\bwrapInfo\.x\b/wrapOffset.x/g
s/\bwrapInfo\.y\b/wrapOffset.y/g
s/\bwrapInfo\.z\b/cascadeReserved.x/g
s/\bwrapInfo\.w\b/cascadeReserved.y/g
s/offsetof\(([A-Za-z_:]*)CsmCascadeGpu, splitTexel\)/offsetof(\1CsmCascadeGpu, splitNearM)/g
s/offsetof\(([A-Za-z_:]*)CsmCascadeGpu, depthInfo\)/offsetof(\1CsmCascadeGpu, blendStartM)/g
s/offsetof\(([A-Za-z_:]*)CsmCascadeGpu, wrapInfo\)/offsetof(\1CsmCascadeGpu, wrapOffset)/g
# The block (CsmUniforms / csmU): only through names that are csm's block.
s/\b(csmU|u|uniforms\(\)|uniforms_)\.cameraForward\.xyz\b/\1.cameraForwardWs/g
s/\b(csmU|u|uniforms\(\)|uniforms_)\.cameraForward\.w\b/\1.shadowFarM/g
s/\b(csmU|u|uniforms\(\)|uniforms_)\.params\.x\b/\1.blendBand/g
s/\b(csmU|u|uniforms\(\)|uniforms_)\.params\.y\b/\1.normalOffsetTexels/g
s/\b(csmU|u|uniforms\(\)|uniforms_)\.params\.z\b/\1.resolution/g
s/\b(csmU|u|uniforms\(\)|uniforms_)\.params\.w\b/\1.invResolution/g
s/\b(csmU|u|uniforms\(\)|uniforms_)\.counts\.x\b/\1.cascadeCount/g
s/\b(csmU|u|uniforms\(\)|uniforms_)\.counts\.y\b/\1.nonEmptyMask/g
s/\b(csmU|u|uniforms\(\)|uniforms_)\.counts\.z\b/\1.debugMode/g
s/\b(csmU|u|uniforms\(\)|uniforms_)\.counts\.w\b/\1.wrappedLayers/g
s/\bbiasParams\.x\b/depthFloorTexels/g
s/\bbiasParams\.y\b/depthFloorQuantum/g
s/\bbiasParams\.z\b/biasReserved.x/g
s/\bbiasParams\.w\b/biasReserved.y/g
s/\bsoftParams\.x\b/tanHalfLightAngle/g
s/\bsoftParams\.y\b/maxPenumbraRadiusM/g
s/\bsoftParams\.z\b/softReserved.x/g
s/\bsoftParams\.w\b/softReserved.y/g
s/offsetof\(([A-Za-z_:]*)CsmUniforms, cameraForward\)/offsetof(\1CsmUniforms, cameraForwardWs)/g
s/offsetof\(([A-Za-z_:]*)CsmUniforms, params\)/offsetof(\1CsmUniforms, blendBand)/g
s/offsetof\(([A-Za-z_:]*)CsmUniforms, counts\)/offsetof(\1CsmUniforms, cascadeCount)/g
s/offsetof\(([A-Za-z_:]*)CsmUniforms, biasParams\)/offsetof(\1CsmUniforms, depthFloorTexels)/g
s/offsetof\(([A-Za-z_:]*)CsmUniforms, softParams\)/offsetof(\1CsmUniforms, tanHalfLightAngle)/g
# Comments that name the old fields by position.
s/\bCsmUniforms\.counts\.z\b/CsmUniforms.debugMode/g
s/\bCsmUniforms\.counts\.w\b/CsmUniforms.wrappedLayers/g
s/\bcounts\.w = 1\b/wrappedLayers = 1/g
s/\bcounts\.w != 0\b/wrappedLayers != 0/g
s/\bparams\.y x reach\b/normalOffsetTexels x reach/g
s/\bdepthInfo\.zw\b/worldTexelOrigin/g
