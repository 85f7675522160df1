// The fly-through's keyboard state is event-driven: a tap between two frames is not lost.
#include <gtest/gtest.h>

#include "sample_world/key_state.hpp"

namespace {

constexpr int kW = 87, kF1 = 290;

TEST(KeyState, TapShorterThanAFrameStillCounts) {
  world::KeyState k;
  // Press and release both arrive before the next frame reads the keys.
  k.event(kW, true);
  k.event(kW, false);
  EXPECT_TRUE(k.active(kW));   // moves for this frame
  EXPECT_TRUE(k.pressed(kW));  // and a toggle fires
  k.endFrame();
  EXPECT_FALSE(k.active(kW));  // but only for one frame
  EXPECT_FALSE(k.pressed(kW));
}

TEST(KeyState, HeldKeyStaysActiveAndTogglesOncePerPress) {
  world::KeyState k;
  k.event(kF1, true);
  EXPECT_TRUE(k.pressed(kF1));
  k.endFrame();
  k.event(kF1, true);  // key repeat: still the same press
  EXPECT_TRUE(k.active(kF1));
  EXPECT_FALSE(k.pressed(kF1));
  k.endFrame();
  k.event(kF1, false);
  EXPECT_FALSE(k.active(kF1));
  k.event(kF1, true);  // a second press toggles again
  EXPECT_TRUE(k.pressed(kF1));
}

TEST(KeyState, OutOfRangeKeysAndFocusLoss) {
  world::KeyState k;
  k.event(-1, true);  // GLFW_KEY_UNKNOWN
  k.event(100000, true);
  EXPECT_FALSE(k.active(-1));
  EXPECT_FALSE(k.active(100000));
  k.event(kW, true);
  k.releaseAll();
  EXPECT_FALSE(k.active(kW));
}

}  // namespace
