#include "flatscan/io/pairs_csv.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "flatscan/io/csv_table.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

constexpr double kMaxThicknessMm = 5.0;  // the bound of inspect --thickness

double ParseThickness(const std::string& text, const std::string& name, int line) {
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(value) || value < 0 ||
      value > kMaxThicknessMm)
    ThrowInputError("{}: line {}: thickness '{}' must be a number of mm in [0, {}]", name, line, text,
                    kMaxThicknessMm);
  return value;
}

}  // namespace

std::vector<PairEntry> ReadPairsCsv(const std::filesystem::path& path) {
  const std::string name = path.string();
  const std::string expected = "expected a CSV with the columns id,left,right[,thickness][,part,appraiser,trial]";
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) ThrowInputError("{}: is a folder ({})", name, expected);
  std::ifstream in(path, std::ios::binary);
  if (!in) ThrowInputError("{}: cannot open pairs file ({})", name, expected);
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::vector<CsvRecord> records = ParseCsv(buffer.str(), name);

  // Column order from the header, or the three columns of a file without one.
  std::vector<std::string> columns = {"id", "left", "right"};
  size_t first = 0;
  const auto known = [](const std::string& c) {
    return c == "id" || c == "left" || c == "right" || c == "thickness" || c == "part" || c == "appraiser" ||
           c == "trial";
  };
  const bool header = !records.empty() && (records[0].fields[0] == "id" ||
                                           std::all_of(records[0].fields.begin(), records[0].fields.end(), known));
  if (header) {
    columns = records[0].fields;
    first = 1;
    for (const std::string& c : columns)
      if (!known(c))
        ThrowInputError("{}: line 1: unknown column '{}' (the columns are id, left, right and optionally thickness, "
                        "part, appraiser, trial)",
                        name, c);
    for (const char* required : {"id", "left", "right"})
      if (std::find(columns.begin(), columns.end(), required) == columns.end())
        ThrowInputError("{}: line 1: the header has no column '{}' ({})", name, required, expected);
  }
  const auto column = [&](const std::string& c) {
    return static_cast<int>(std::find(columns.begin(), columns.end(), c) - columns.begin());
  };
  const int id = column("id"), left = column("left"), right = column("right"), thickness = column("thickness");
  const int part = column("part"), appraiser = column("appraiser"), trial = column("trial");
  const auto cell = [&](const CsvRecord& rec, int c) {
    return c < static_cast<int>(columns.size()) ? rec.fields[c] : std::string();
  };

  const std::filesystem::path base = path.parent_path();
  auto resolve = [&](const std::string& p) { return std::filesystem::path(p).is_absolute() ? p : (base / p).string(); };
  std::vector<PairEntry> out;
  for (size_t r = first; r < records.size(); ++r) {
    const CsvRecord& rec = records[r];
    if (rec.fields.size() != columns.size())
      ThrowInputError("{}: line {} has {} fields (expected {}: {})", name, rec.line, rec.fields.size(), columns.size(),
                      fmt::join(columns, ","));
    PairEntry e{rec.fields[id], rec.fields[left], rec.fields[right], std::nullopt, {}};
    for (const auto& [value, what] : {std::pair{&e.id, "id"}, {&e.left, "left image"}, {&e.right, "right image"}})
      if (value->empty()) ThrowInputError("{}: line {}: the {} is empty", name, rec.line, what);
    if (thickness < static_cast<int>(columns.size()) && !rec.fields[thickness].empty())
      e.thickness_mm = ParseThickness(rec.fields[thickness], name, rec.line);
    e.study = {cell(rec, part), cell(rec, appraiser), cell(rec, trial)};
    e.left = resolve(e.left);
    e.right = resolve(e.right);
    out.push_back(std::move(e));
  }
  if (out.empty()) ThrowInputError("{}: no pairs listed ({})", name, expected);
  return out;
}

std::string PairsCsvText(const std::vector<PairEntry>& pairs) {
  bool with_thickness = false, with_study = false;
  for (const PairEntry& p : pairs) {
    with_thickness |= p.thickness_mm.has_value();
    with_study |= !p.study.Empty();
  }
  std::string text = fmt::format("id,left,right{}{}\n", with_thickness ? ",thickness" : "",
                                 with_study ? ",part,appraiser,trial" : "");
  for (const PairEntry& p : pairs) {
    text += fmt::format("{},{},{}", CsvField(p.id), CsvField(p.left), CsvField(p.right));
    if (with_thickness) text += p.thickness_mm ? fmt::format(",{}", *p.thickness_mm) : ",";
    if (with_study)
      text += fmt::format(",{},{},{}", CsvField(p.study.part), CsvField(p.study.appraiser), CsvField(p.study.trial));
    text += "\n";
  }
  return text;
}

}  // namespace flatscan
