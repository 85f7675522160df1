#include "csm/error.hpp"

#include <cstdio>

namespace csm {

std::string ValidationError::message() const {
  if (text) return field + " = '" + *text + "' is invalid: allowed " + allowed;
  char number[64];
  std::snprintf(number, sizeof number, "%.17g", value);
  return field + " = " + number + " is invalid: allowed " + allowed;
}

}  // namespace csm
