// Validation errors and a small result type. The cascade math refuses invalid input instead of
// clamping it: every refusal names the field, the value it had and the range it must lie in.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <variant>

namespace csm {

/// One refused input: `field` is the dotted name a user would write ("settings.resolution"),
/// `value` the offending value (may be NaN or infinite), `allowed` the accepted range in words.
struct ValidationError {
  std::string field;
  double value = 0.0;
  std::string allowed;
  /// The offending value as written, for inputs that are names, not numbers (a kernel's name):
  /// message() quotes it instead of `value`.
  std::optional<std::string> text{};

  /// "settings.resolution = 300 is invalid: allowed a power of two in [256, 16384]", or with
  /// `text`: "kernel = 'tent4' is invalid: allowed one of 1tap, tent3x3, ...".
  [[nodiscard]] std::string message() const;
};

/// Either a value or the ValidationError that prevented computing it (a C++20 stand-in for
/// std::expected). Accessing the wrong alternative throws std::bad_variant_access.
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}                // NOLINT: implicit by design
  Result(ValidationError error) : v_(std::move(error)) {}  // NOLINT: implicit by design

  [[nodiscard]] bool ok() const noexcept { return v_.index() == 0; }
  explicit operator bool() const noexcept { return ok(); }
  [[nodiscard]] const T& value() const& { return std::get<0>(v_); }
  [[nodiscard]] T& value() & { return std::get<0>(v_); }
  [[nodiscard]] T&& value() && { return std::get<0>(std::move(v_)); }
  [[nodiscard]] const ValidationError& error() const { return std::get<1>(v_); }

 private:
  std::variant<T, ValidationError> v_;
};

}  // namespace csm
