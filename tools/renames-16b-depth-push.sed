# Issue 16 (16b), step 5, second part: the depth pass's push constants, one struct per render
# mode instead of fields whose meaning changed with it (C++: DepthPushPerLayer and
# DepthPushLayered in shadows/src/vulkan/vk_util.hpp). Apply ONLY to shadows/shaders/csm_depth*.vert
# (the engine's own shaders also call a push-constant member pc.modelCr):
#   sed -i -E -f tools/renames-16b-depth-push.sed shadows/shaders/csm_depth*.vert
# The push_constant block declarations in those two shaders: take them from this branch.
s/\bpc\.modelToClip\b/pc.modelToShadowClip/g
s/\bpc\.modelCr\b/pc.modelToCameraRelative/g
s/\bpc\.cascadeOrMask\b/pc.cascadeMask/g
