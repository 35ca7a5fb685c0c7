#pragma once
// Pairs files: a CSV listing stereo pairs, one per line, `id,left,right`, with a header
// line `id,left,right`; image paths relative to the CSV's folder (or absolute). Written
// by `flatscan simulate` (pairs.csv) and read by `flatscan inspect --pairs`.
#include <filesystem>
#include <string>
#include <vector>

namespace flatscan {

struct PairEntry {
  std::string id;
  std::string left, right;  // as written in the file (relative to its folder or absolute)
};

// Throws InputError naming the file (and the line) when it cannot be read, a line does
// not have three columns, or it lists no pair. Returned paths are resolved against the
// CSV's folder.
std::vector<PairEntry> ReadPairsCsv(const std::filesystem::path& path);

// The file's text: the header, then one line per entry.
std::string PairsCsvText(const std::vector<PairEntry>& pairs);

}  // namespace flatscan
