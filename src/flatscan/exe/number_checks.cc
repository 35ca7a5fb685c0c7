#include "flatscan/exe/number_checks.h"

#include <charconv>
#include <cmath>
#include <optional>

#include <fmt/format.h>

namespace flatscan {
namespace {

// The whole text as a decimal number (a leading '+' allowed), or nullopt. A number
// beyond the range of a double (1e400, 1e-400) is returned as infinity or zero with
// `*out_of_range` set, so that the message can say it is out of range.
std::optional<double> ParseReal(const std::string& text, bool* out_of_range = nullptr) {
  const char* first = text.data();
  const char* last = first + text.size();
  if (first != last && *first == '+') ++first;
  double value = 0;
  const auto [end, error] = std::from_chars(first, last, value, std::chars_format::general);
  if (first == last || end != last) return std::nullopt;
  if (error == std::errc::result_out_of_range) {
    if (out_of_range) *out_of_range = true;
    return 0.0;
  }
  if (error != std::errc()) return std::nullopt;
  return value;
}

std::string Interval(double min, double max, bool min_open) {
  return fmt::format("{}{}, {}]", min_open ? "(" : "[", min, max);
}

}  // namespace

CLI::Validator RealIn(double min, double max, bool min_open) {
  const std::string range = Interval(min, max, min_open);
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        bool out_of_range = false;
        const std::optional<double> value = ParseReal(text, &out_of_range);
        if (!value) return fmt::format("not a number: '{}' (expected a number in {})", text, range);
        if (!std::isfinite(*value)) return fmt::format("must be a finite number, got '{}'", text);
        if (out_of_range || *value < min || *value > max || (min_open && *value == min))
          return fmt::format("must be in {}, got {}", range, text);
        return "";
      },
      "NUMBER in " + range);
}

CLI::Validator IntegerIn(long long min, long long max) {
  const std::string range = fmt::format("[{}, {}]", min, max);
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        const char* first = text.data();
        const char* last = first + text.size();
        if (first != last && *first == '+') ++first;
        long long value = 0;
        const auto [end, error] = std::from_chars(first, last, value);
        if (first == last || end != last || error == std::errc::invalid_argument) {
          if (ParseReal(text)) return fmt::format("must be a whole number in {}, got {}", range, text);
          return fmt::format("not a number: '{}' (expected a whole number in {})", text, range);
        }
        if (error == std::errc::result_out_of_range || value < min || value > max)
          return fmt::format("must be in {}, got {}", range, text);
        return "";
      },
      "INTEGER in " + range);
}

}  // namespace flatscan
