#pragma once
// Error reporting shared by every stage.
//
// InputError is thrown for anything a user can fix (a bad file, a missing key, an
// image that does not fit the rig). The CLI maps it to exit code 2 ("could not
// measure") and prints its message, which must name the file or field and say what
// was expected. Programming errors use FLATSCAN_CHECK and are not user-facing.
//
// The library names its own fields, never a command-line flag: an error in one field
// of an options struct carries the field's name (ThrowFieldError("tolerance_mm",
// ...), what() "tolerance_mm: expected ..."), and a command that fills the field from
// a flag reports it under the flag's name ("--tolerance: expected ...", exe/).
#include <stdexcept>
#include <string>

#include <fmt/format.h>

namespace flatscan {

class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(message) {}
  // An error in one named field: what() is "<field>: <detail>".
  InputError(const std::string& field, const std::string& detail)
      : std::runtime_error(field + ": " + detail), field_(field), detail_(detail) {}
  const std::string& field() const { return field_; }    // empty unless a field error
  const std::string& detail() const { return detail_; }  // the message without the field

 private:
  std::string field_, detail_;
};

template <typename... Args>
[[noreturn]] void ThrowInputError(fmt::format_string<Args...> format, Args&&... args) {
  throw InputError(fmt::format(format, std::forward<Args>(args)...));
}

template <typename... Args>
[[noreturn]] void ThrowFieldError(const std::string& field, fmt::format_string<Args...> format, Args&&... args) {
  throw InputError(field, fmt::format(format, std::forward<Args>(args)...));
}

}  // namespace flatscan

// Internal invariant: throws std::logic_error with the failed condition and location.
#define FLATSCAN_CHECK(cond)                                                          \
  do {                                                                                \
    if (!(cond))                                                                      \
      throw std::logic_error(fmt::format("check failed: {} ({}:{})", #cond, __FILE__, \
                                         __LINE__));                                  \
  } while (0)
