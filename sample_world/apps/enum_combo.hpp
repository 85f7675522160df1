// An ImGui combo over every value of an enum, each shown by its one spelling (the name the CLI,
// the config and report.json use): no index casts that depend on the enum's order.
#pragma once

#include <imgui.h>

#include <array>
#include <cstddef>

namespace world {

/// Shows `label` with `value` selected among `all`, each named by `name(v)`; true when the user
/// picked another value (then `value` holds it).
template <class T, std::size_t N, class Name>
bool enumCombo(const char* label, T& value, const std::array<T, N>& all, Name name) {
  bool changed = false;
  if (ImGui::BeginCombo(label, name(value))) {
    for (const T v : all) {
      const bool selected = v == value;
      if (ImGui::Selectable(name(v), selected) && !selected) {
        value = v;
        changed = true;
      }
      if (selected) ImGui::SetItemDefaultFocus();
    }
    ImGui::EndCombo();
  }
  return changed;
}

}  // namespace world
