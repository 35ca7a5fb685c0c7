#pragma once
// Checks made before a text goes to cv::FileStorage's parser, which has no bounds of its
// own and, for YAML, loops forever on some layouts. Each was found by the fuzz targets
// (fuzz/): a 136-byte file of nested brackets ("[[[[...") kept the parser busy for more
// than two minutes; an 18-byte plane file ("%YAML:1.\n L:1\n- \n-") never returned.
// flatscan's rig, plane and scene files are a few kilobytes, one top-level map, with
// brackets at most two deep.
#include <optional>
#include <string>
#include <string_view>

namespace flatscan {

constexpr size_t kMaxFileStorageBytes = 1 << 20;  // 1 MB
constexpr int kMaxFileStorageNesting = 8;         // [ and { inside each other

// Why `text` is not handed to the parser, or nullopt when it may be. With `yaml` the
// text is checked as YAML whatever it starts with (scene files, always read as YAML);
// otherwise its YAML layout is checked only when it starts with "%YAML", as OpenCV
// reads anything else as XML or JSON.
std::optional<std::string> FileStorageLimitExceeded(std::string_view text, bool yaml = false);

// Why a YAML text does not have the layout of one top-level map, or nullopt when it
// has. Every line must be one of: blank; a comment; a key at the start of the line;
// indented (part of a value, after the first key); before the first key, "%"
// directives and at most one "---"; and at most one "..." after which only blank lines
// and comments follow.
//
// Why: after its top-level collection OpenCV 4.6's YAML parser skips three characters
// wherever that collection ended and then waits for a document marker; a '-' there
// that does not begin "---" makes it loop without advancing. With the first key at
// the start of a line the top-level map ends only at the end of the text or at a
// "..." line, so with the rules above nothing but blank lines and comments follow.
std::optional<std::string> YamlLayoutProblem(std::string_view text);

}  // namespace flatscan
