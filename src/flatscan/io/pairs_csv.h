#pragma once
// Pairs files: a CSV (RFC 4180) listing stereo pairs, one per record, with a header
// naming the columns: `id,left,right` and optionally `thickness` (mm: the height of the
// part's side face, as `inspect --thickness`, for batches of parts of different
// thickness; an empty cell takes --thickness) and `part`, `appraiser`, `trial` (a gauge
// study's tags, io/study_tags.h; kept in the station's records). Image paths are relative to the
// CSV's folder (or absolute). Written by `flatscan simulate` (pairs.csv, with the
// thickness of each simulated part) and read by `flatscan inspect --pairs`.
//
// Reading: fields may be quoted ("a, b" and "a ""quoted"" name", also across lines); a
// UTF-8 byte-order mark and CRLF line ends are accepted; spaces and tabs around unquoted
// fields are trimmed; blank lines are skipped; the columns may come in any order. A file
// without a header (its first record names no columns) has the three columns id,left,right. Unknown columns are refused (a misspelt
// `thickness` would silently measure with the wrong thickness: 68 um for 0.1 mm).
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "flatscan/io/study_tags.h"
#include "flatscan/io/csv_table.h"  // CsvField

namespace flatscan {

struct PairEntry {
  std::string id;
  std::string left, right;            // as written in the file (relative to its folder or absolute)
  std::optional<double> thickness_mm;  // the `thickness` column, when given for this pair
  StudyTags study;                     // the `part`, `appraiser`, `trial` columns (empty when absent)
};

// Throws InputError naming the file (and the line) when it cannot be read, a record has
// the wrong number of fields, an id or path is empty, a thickness is not a number in
// [0, 5] mm, or it lists no pair. Returned paths are resolved against the CSV's folder.
std::vector<PairEntry> ReadPairsCsv(const std::filesystem::path& path);

// The file's text: the header (with `thickness` when any entry has one), then one
// record per entry; fields are quoted where RFC 4180 needs it.
std::string PairsCsvText(const std::vector<PairEntry>& pairs);

}  // namespace flatscan
