#pragma once
// Small parsers shared by the command-line commands.
#include <optional>
#include <string>
#include <utility>

namespace flatscan {

// "9x6" -> (9, 6); nullopt unless it is two positive integers (at most 100000) around
// an x. (Hand-parsed: std::regex draws false -Wmaybe-uninitialized warnings from GCC 12
// under the sanitizers.)
inline std::optional<std::pair<int, int>> ParseTwoIntegers(const std::string& text) {
  const auto number = [](std::string s) -> std::optional<int> {
    const size_t first = s.find_first_not_of(" \t"), last = s.find_last_not_of(" \t");
    if (first == std::string::npos) return std::nullopt;
    s = s.substr(first, last - first + 1);
    if (s.empty() || s.size() > 6 || s.find_first_not_of("0123456789") != std::string::npos) return std::nullopt;
    const int value = std::stoi(s);
    if (value <= 0 || value > 100000) return std::nullopt;
    return value;
  };
  const size_t x = text.find_first_of("xX");
  if (x == std::string::npos) return std::nullopt;
  const std::optional<int> a = number(text.substr(0, x)), b = number(text.substr(x + 1));
  if (!a || !b) return std::nullopt;
  return std::pair<int, int>(*a, *b);
}

}  // namespace flatscan
