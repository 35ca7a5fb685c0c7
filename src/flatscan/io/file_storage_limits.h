#pragma once
// Limits checked before a text goes to cv::FileStorage's parser, which has no bounds of
// its own: a 136-byte file of nested brackets ("[[[[...") kept it busy for more than two
// minutes (found by fuzz/rig_file_fuzz.cc). flatscan's rig, plane and scene files are a
// few kilobytes with brackets at most two deep.
#include <optional>
#include <string>
#include <string_view>

#include <fmt/format.h>

namespace flatscan {

constexpr size_t kMaxFileStorageBytes = 1 << 20;  // 1 MB
constexpr int kMaxFileStorageNesting = 8;         // [ and { inside each other

// Why `text` is not handed to the parser, or nullopt when it may be.
inline std::optional<std::string> FileStorageLimitExceeded(std::string_view text) {
  if (text.size() > kMaxFileStorageBytes)
    return fmt::format("{} bytes, more than the {} a rig, plane or scene file may have", text.size(),
                       kMaxFileStorageBytes);
  int depth = 0;
  for (const char c : text) {
    if (c == '[' || c == '{') ++depth;
    if (c == ']' || c == '}') --depth;
    if (depth > kMaxFileStorageNesting)
      return fmt::format("brackets nested more than {} deep", kMaxFileStorageNesting);
  }
  return std::nullopt;
}

}  // namespace flatscan
