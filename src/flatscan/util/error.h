#pragma once
// Error reporting shared by every stage.
//
// InputError is thrown for anything a user can fix (a bad file, a missing key, an
// image that does not fit the rig). The CLI maps it to exit code 2 ("could not
// measure") and prints its message, which must name the file or field and say what
// was expected. Programming errors use FLATSCAN_CHECK and are not user-facing.
#include <stdexcept>
#include <string>

#include <fmt/format.h>

namespace flatscan {

class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(message) {}
};

template <typename... Args>
[[noreturn]] void ThrowInputError(fmt::format_string<Args...> format, Args&&... args) {
  throw InputError(fmt::format(format, std::forward<Args>(args)...));
}

}  // namespace flatscan

// Internal invariant: throws std::logic_error with the failed condition and location.
#define FLATSCAN_CHECK(cond)                                                          \
  do {                                                                                \
    if (!(cond))                                                                      \
      throw std::logic_error(fmt::format("check failed: {} ({}:{})", #cond, __FILE__, \
                                         __LINE__));                                  \
  } while (0)
