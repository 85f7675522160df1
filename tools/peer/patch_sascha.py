#!/usr/bin/env python3
"""Local edits to a checkout of SaschaWillems/Vulkan at 9c8e787f for the comparison with the
fly-through (tools/peer/README.md). Usage: patch_sascha.py DIR (the checkout; run once).

- <format> and std::format (not in GCC 12) replaced by string concatenation in
  base/VulkanTools.h;
- anisotropic filtering chosen at run time by SASCHA_ANISO: above 1, the sample as shipped
  (samplerAnisotropy enabled, the glTF samplers at 8x, KTX textures at the device's maximum);
  otherwise off everywhere;
- GPU timestamps around the cascades' depth passes and the scene pass of shadowmappingcascade,
  written at exit to $SASCHA_TS, one line a frame: shadow ms, scene ms.
"""
import sys

if len(sys.argv) != 2:
    sys.exit("usage: patch_sascha.py DIR")
root = sys.argv[1].rstrip("/") + "/"


def edit(path, pairs):
    s = open(root + path).read()
    for old, new in pairs:
        if old in s and not (old in new and new in s):
            s = s.replace(old, new)
        elif new not in s:
            sys.exit(f"{path}: the text to replace is not there (not 9c8e787f?): {old[:60]!r}")
    open(root + path, "w").write(s)

ANISO = '(getenv("SASCHA_ANISO") && atoi(getenv("SASCHA_ANISO")) > 1)'

edit("base/VulkanTools.h", [
    ("#include <format>", "#include <string>"),
    ('std::format("Fatal : VkResult is {} in {} at line {}", vks::tools::errorString(res), '
     "__FILE__, __LINE__);",
     '"Fatal : VkResult is " + vks::tools::errorString(res) + " in " + std::string(__FILE__) + '
     '" at line " + std::to_string(__LINE__);'),
])
edit("base/VulkanglTFModel.cpp", [
    ("#include \"VulkanglTFModel.h\"", "#include <cstdlib>\n#include \"VulkanglTFModel.h\""),
    ("\t\t.anisotropyEnable = VK_TRUE,\n\t\t.maxAnisotropy = 8.0f,",
     f"\t\t.anisotropyEnable = {ANISO} ? VK_TRUE : VK_FALSE,\n"
     f"\t\t.maxAnisotropy = {ANISO} ? 8.0f : 1.0f,"),
])
edit("examples/shadowmappingcascade/shadowmappingcascade.cpp", [
    ("\t\tenabledFeatures.samplerAnisotropy = deviceFeatures.samplerAnisotropy;",
     f"\t\tenabledFeatures.samplerAnisotropy = {ANISO} ? deviceFeatures.samplerAnisotropy : "
     "VK_FALSE;"),
    ("\t~VulkanExample()\n\t{\n",
     "\t~VulkanExample()\n\t{\n\t\tvkDeviceWaitIdle(device);\n\t\ttsWrite();\n"
     "\t\tif (tsPool != VK_NULL_HANDLE) vkDestroyQueryPool(device, tsPool, nullptr);\n"),
    ("\tvoid buildCommandBuffer()\n\t{\n",
     """\t// GPU timestamps of the cascades' depth passes and the scene pass, per frame, written to
\t// $SASCHA_TS at exit (one line a frame: shadow ms, scene ms).
\tVkQueryPool tsPool = VK_NULL_HANDLE;
\tstd::vector<int> tsPending;
\tstd::vector<std::pair<double, double>> tsFrames;
\tvoid tsRead(uint32_t b) {
\t\tif (tsPool == VK_NULL_HANDLE || !tsPending[b]) return;
\t\tuint64_t t[3];
\t\tVK_CHECK_RESULT(vkGetQueryPoolResults(device, tsPool, 3 * b, 3, sizeof(t), t, sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
\t\tconst double p = vulkanDevice->properties.limits.timestampPeriod * 1e-6;
\t\ttsFrames.push_back({double(t[1] - t[0]) * p, double(t[2] - t[1]) * p});
\t\ttsPending[b] = 0;
\t}
\tvoid tsWrite() {
\t\tconst char* f = getenv("SASCHA_TS");
\t\tif (!f) return;
\t\tfor (uint32_t b = 0; b < tsPending.size(); ++b) tsRead(b);
\t\tFILE* out = fopen(f, "w");
\t\tif (!out) return;
\t\tfor (auto& [a, c] : tsFrames) fprintf(out, "%.3f %.3f\\n", a, c);
\t\tfclose(out);
\t}

\tvoid buildCommandBuffer()
\t{
\t\tif (tsPool == VK_NULL_HANDLE) {
\t\t\tVkQueryPoolCreateInfo qci{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
\t\t\tqci.queryType = VK_QUERY_TYPE_TIMESTAMP;
\t\t\tqci.queryCount = 3 * uint32_t(drawCmdBuffers.size());
\t\t\tVK_CHECK_RESULT(vkCreateQueryPool(device, &qci, nullptr, &tsPool));
\t\t\ttsPending.assign(drawCmdBuffers.size(), 0);
\t\t}
\t\ttsRead(currentBuffer);
"""),
    ("\t\tVK_CHECK_RESULT(vkBeginCommandBuffer(cmdBuffer, &cmdBufInfo));\n",
     "\t\tVK_CHECK_RESULT(vkBeginCommandBuffer(cmdBuffer, &cmdBufInfo));\n"
     "\t\tvkCmdResetQueryPool(cmdBuffer, tsPool, 3 * currentBuffer, 3);\n"
     "\t\tvkCmdWriteTimestamp(cmdBuffer, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, tsPool, "
     "3 * currentBuffer);\n"),
    ("\t\t/*\n\t\t\tNote: Explicit synchronization",
     "\t\tvkCmdWriteTimestamp(cmdBuffer, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, tsPool, "
     "3 * currentBuffer + 1);\n\t\t/*\n\t\t\tNote: Explicit synchronization"),
    ("\t\t\tvkCmdEndRenderPass(cmdBuffer);\n\t\t}\n\n\t\tVK_CHECK_RESULT(vkEndCommandBuffer(cmdBuffer));",
     "\t\t\tvkCmdEndRenderPass(cmdBuffer);\n\t\t}\n"
     "\t\tvkCmdWriteTimestamp(cmdBuffer, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, tsPool, "
     "3 * currentBuffer + 2);\n\t\ttsPending[currentBuffer] = 1;\n\n"
     "\t\tVK_CHECK_RESULT(vkEndCommandBuffer(cmdBuffer));"),
])
print("patched", root)
