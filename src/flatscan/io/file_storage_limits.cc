#include "flatscan/io/file_storage_limits.h"

#include <cctype>

#include <fmt/format.h>

namespace flatscan {

namespace {

std::string_view TrimRight(std::string_view s) {
  while (!s.empty() && (s.back() == ' ' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

bool IsBlankOrComment(std::string_view line) {
  const size_t first = line.find_first_not_of(" \r");
  return first == std::string_view::npos || line[first] == '#';
}

// How a line's first character reads to a person: 'x', or its code when not printable.
std::string Shown(char c) {
  const auto u = static_cast<unsigned char>(c);
  if (c == '\t') return "a tab (YAML indents with spaces)";
  return std::isprint(u) ? fmt::format("'{}'", c) : fmt::format("byte 0x{:02X}", u);
}

}  // namespace

std::optional<std::string> FileStorageLimitExceeded(std::string_view text, bool yaml) {
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
  if (yaml || text.rfind("%YAML", 0) == 0) return YamlLayoutProblem(text);
  return std::nullopt;
}

std::optional<std::string> YamlLayoutProblem(std::string_view text) {
  enum class Part { kHeader, kMap, kAfterEnd } part = Part::kHeader;
  bool document_marker_seen = false;
  int number = 0;
  for (size_t begin = 0; begin < text.size();) {
    const size_t end = std::min(text.find('\n', begin), text.size());
    const std::string_view line = text.substr(begin, end - begin);
    begin = end + 1;
    ++number;
    if (IsBlankOrComment(line)) continue;
    const std::string_view trimmed = TrimRight(line);
    if (part == Part::kAfterEnd)
      return fmt::format("line {}: text after the end of the document ('...' on an earlier line)", number);
    const char c = line[0];
    if (trimmed == "...") {
      part = Part::kAfterEnd;
    } else if (trimmed == "---" && part == Part::kHeader && !document_marker_seen) {
      document_marker_seen = true;
    } else if (c == '%' && part == Part::kHeader && !document_marker_seen) {
      // a directive such as %YAML:1.0
    } else if (std::isalnum(static_cast<unsigned char>(c)) || c == '_') {
      part = Part::kMap;
    } else if (c == ' ' && part == Part::kMap) {
      // part of the value of the key above
    } else if (trimmed == "---") {
      return fmt::format("line {}: a second document ('---'); the file must be one YAML map", number);
    } else if (c == ' ') {
      return fmt::format("line {} is indented, but the top-level keys start at the beginning of a line", number);
    } else {
      return fmt::format(
          "line {} starts with {}: the file must be one YAML map, its keys at the start of a line and their values "
          "indented",
          number, Shown(c));
    }
  }
  return std::nullopt;
}

}  // namespace flatscan
