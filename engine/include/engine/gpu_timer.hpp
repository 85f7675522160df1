// GPU timing with timestamp queries: one query pool per frame in flight, named scopes around
// passes, results in milliseconds once the frame's fence has passed.
#pragma once

#include <vulkan/vulkan.h>

#include <array>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "engine/render_target.hpp"

namespace engine {

class Context;

/// Measures named GPU scopes: `timer.beginFrame(frame.cmd, frame.slot)`, then
/// `timer.begin(cmd, "shadow pass")` ... `timer.end(cmd, "shadow pass")`. A slot's results are
/// read when the slot is begun again (its fence has passed by then) or by collect() after the
/// target's waitIdle(). Without timestamp support every call is a no-op and results are empty.
class GpuTimer {
 public:
  /// Creates one pool of 2 * maxScopes queries per frame slot.
  GpuTimer(Context& ctx, uint32_t maxScopes = 32);
  ~GpuTimer();
  GpuTimer(const GpuTimer&) = delete;
  GpuTimer& operator=(const GpuTimer&) = delete;

  /// Reads the results `slot` holds from its previous frame (its fence must have passed), then
  /// records the reset of its queries into `cmd` (outside any rendering).
  void beginFrame(VkCommandBuffer cmd, uint32_t slot);
  /// Writes the start timestamp of scope `name` (after all earlier commands).
  void begin(VkCommandBuffer cmd, std::string_view name);
  /// Writes the end timestamp of scope `name`.
  void end(VkCommandBuffer cmd, std::string_view name);
  /// Reads the results of `slot` now; the GPU must have finished that slot's frame.
  void collect(uint32_t slot);
  /// Milliseconds per scope of the latest frame whose results were read.
  const std::map<std::string, double>& results() const { return results_; }
  /// Whether the device writes timestamps on the engine's queue.
  bool supported() const { return supported_; }

 private:
  struct Scope {
    std::string name;
    uint32_t beginQuery = 0;
    bool ended = false;
  };
  struct SlotState {
    VkQueryPool pool = VK_NULL_HANDLE;
    std::vector<Scope> scopes;
    uint32_t used = 0;     // queries written
    bool pending = false;  // holds results not read yet
  };
  void releasePools() noexcept;

  Context* ctx_;
  uint32_t maxScopes_;
  bool supported_ = false;
  double periodNs_ = 1.0;
  uint64_t mask_ = ~uint64_t(0);
  std::array<SlotState, kFramesInFlight> slots_{};
  uint32_t current_ = 0;
  std::map<std::string, double> results_;
};

}  // namespace engine
