#include "csm/error.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace csm {

std::string ValidationError::message() const {
  if (text) return field + " = '" + *text + "' is invalid: allowed " + allowed;
  // Whole numbers as integers (300, 1500000000); others in the shortest form that reads back as
  // the same double (1e-07, not 9.9999999999999995e-08).
  char number[64];
  if (std::abs(value) < 1e15 && std::trunc(value) == value) {
    std::snprintf(number, sizeof number, "%.0f", value);
  } else {
    for (int digits = 1; digits <= 17; ++digits) {
      std::snprintf(number, sizeof number, "%.*g", digits, value);
      if (std::strtod(number, nullptr) == value) break;
    }
  }
  return field + " = " + number + " is invalid: allowed " + allowed;
}

}  // namespace csm
