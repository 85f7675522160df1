// Keyboard state fed by events (GLFW's key callback), not by polling once per frame: a key
// pressed and released between two frames still counts as pressed for the frame that follows
// (a tap is never lost), and toggles fire once per press however short.
#pragma once

#include <bitset>

namespace world {

class KeyState {
 public:
  static constexpr int kKeys = 512;  // GLFW_KEY_LAST is 348

  /// From the key callback: `down` true for press (and repeat), false for release.
  void event(int key, bool down) noexcept {
    if (key < 0 || key >= kKeys) return;
    if (down && !held_[key]) pressed_[key] = true;
    held_[key] = down;
  }
  /// Held now, or pressed at some time since the last endFrame() (a tap shorter than a frame).
  [[nodiscard]] bool active(int key) const noexcept {
    return key >= 0 && key < kKeys && (held_[key] || pressed_[key]);
  }
  /// Pressed (went down) since the last endFrame(): for toggles and one-shot actions.
  [[nodiscard]] bool pressed(int key) const noexcept {
    return key >= 0 && key < kKeys && pressed_[key];
  }
  /// Called once per frame after input has been read.
  void endFrame() noexcept { pressed_.reset(); }
  /// Everything released (focus lost: no key stays stuck down).
  void releaseAll() noexcept {
    held_.reset();
    pressed_.reset();
  }

 private:
  std::bitset<kKeys> held_;
  std::bitset<kKeys> pressed_;
};

}  // namespace world
