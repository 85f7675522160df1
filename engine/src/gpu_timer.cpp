#include "engine/gpu_timer.hpp"

#include <stdexcept>
#include <string>

#include "engine/context.hpp"
#include "engine/debug.hpp"
#include "engine/errors.hpp"
#include "vk_struct.hpp"

namespace engine {

GpuTimer::GpuTimer(Context& ctx, uint32_t maxScopes) : ctx_(&ctx), maxScopes_(maxScopes) {
  const uint32_t bits = ctx.timestampValidBits();
  supported_ = bits > 0 && ctx.properties().limits.timestampPeriod > 0.0f;
  if (!supported_) return;
  periodNs_ = ctx.properties().limits.timestampPeriod;
  mask_ = bits >= 64 ? ~uint64_t(0) : (uint64_t(1) << bits) - 1;
  for (uint32_t i = 0; i < kFramesInFlight; ++i) {
    auto info = detail::vkStruct<VkQueryPoolCreateInfo>(VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO);
    info.queryType = VK_QUERY_TYPE_TIMESTAMP;
    info.queryCount = 2 * maxScopes;
    VkResult r = vkCreateQueryPool(ctx.device(), &info, nullptr, &slots_[i].pool);
    if (r != VK_SUCCESS) {
      releasePools();
      throwVulkanError(r, "vkCreateQueryPool", __FILE__, __LINE__);
    }
    setDebugName(ctx.device(), slots_[i].pool, "engine.gpu_timer.frame" + std::to_string(i));
  }
}

GpuTimer::~GpuTimer() {
  releasePools();
}

void GpuTimer::releasePools() noexcept {
  for (SlotState& s : slots_) {
    if (s.pool) vkDestroyQueryPool(ctx_->device(), s.pool, nullptr);
    s.pool = VK_NULL_HANDLE;
  }
}

void GpuTimer::collect(uint32_t slot) {
  SlotState& s = slots_.at(slot);
  if (!supported_ || !s.pending) return;
  s.pending = false;
  results_.clear();
  for (const Scope& scope : s.scopes) {
    if (!scope.ended) continue;  // an unended scope's second query was never written
    uint64_t ticks[2] = {0, 0};
    // The caller guarantees the frame finished, so WAIT returns at once.
    ENGINE_VK_CHECK(vkGetQueryPoolResults(ctx_->device(), s.pool, scope.beginQuery, 2,
                                          sizeof(ticks), ticks, sizeof(uint64_t),
                                          VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
    const uint64_t begin = ticks[0] & mask_;
    const uint64_t end = ticks[1] & mask_;
    const uint64_t delta = (end - begin) & mask_;  // modular: survives one wrap of the counter
    results_[scope.name] += double(delta) * periodNs_ * 1e-6;
  }
}

void GpuTimer::beginFrame(VkCommandBuffer cmd, uint32_t slot) {
  if (!supported_) return;
  collect(slot);
  current_ = slot;
  SlotState& s = slots_.at(slot);
  s.scopes.clear();
  s.used = 0;
  vkCmdResetQueryPool(cmd, s.pool, 0, 2 * maxScopes_);
  s.pending = true;
}

void GpuTimer::begin(VkCommandBuffer cmd, std::string_view name) {
  if (!supported_) return;
  SlotState& s = slots_[current_];
  if (s.used + 2 > 2 * maxScopes_)
    throw std::length_error("GpuTimer: more than " + std::to_string(maxScopes_) +
                            " scopes in one frame");
  s.scopes.push_back({std::string(name), s.used, false});
  vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, s.pool, s.used);
  s.used += 2;
}

void GpuTimer::end(VkCommandBuffer cmd, std::string_view name) {
  if (!supported_) return;
  SlotState& s = slots_[current_];
  for (auto it = s.scopes.rbegin(); it != s.scopes.rend(); ++it)
    if (!it->ended && it->name == name) {
      vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, s.pool, it->beginQuery + 1);
      it->ended = true;
      return;
    }
  throw std::logic_error("GpuTimer::end(\"" + std::string(name) + "\") without begin");
}

}  // namespace engine
