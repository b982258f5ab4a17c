/**
 * @file loop_text.h
 * @brief How LOOPMODEL writes numbers into its sentences, its plan goals' literals and its run parameters.
 */
#pragma once

#include <sstream>
#include <string>

namespace xpersif {
namespace loop {

/// @p value as an ostream writes it by default (six significant digits; "inf", "nan").
inline std::string literalNumber(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

}  // namespace loop
}  // namespace xpersif
