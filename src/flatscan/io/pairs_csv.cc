#include "flatscan/io/pairs_csv.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "flatscan/util/error.h"

namespace flatscan {
namespace {

// A record: its fields and the line it starts on.
struct Record {
  std::vector<std::string> fields;
  int line = 0;
};

// RFC 4180 records of `text` (after a UTF-8 BOM). Written here rather than taken from a
// library (Debian's libcsv is a callback C API): it is short, and the errors must name
// the file and line as every reader of ours does.
std::vector<Record> ParseCsv(std::string_view text, const std::string& name) {
  if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
  std::vector<Record> records;
  Record record;
  std::string field;
  bool quoted = false, field_was_quoted = false, record_has_content = false;
  int line = 1;
  record.line = 1;
  const auto trim = [](std::string& s) {
    const size_t first = s.find_first_not_of(" \t"), last = s.find_last_not_of(" \t");
    s = first == std::string::npos ? "" : s.substr(first, last - first + 1);
  };
  const auto end_field = [&] {
    if (!field_was_quoted) trim(field);
    record.fields.push_back(std::move(field));
    field.clear();
    field_was_quoted = false;
  };
  const auto end_record = [&] {
    end_field();
    const bool blank = record.fields.size() == 1 && record.fields[0].empty() && !record_has_content;
    if (!blank) records.push_back(std::move(record));
    record = Record{};
    record.line = line + 1;
    record_has_content = false;
  };
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c == '"' && i + 1 < text.size() && text[i + 1] == '"') {
        field.push_back('"');
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        if (c == '\n') ++line;
        field.push_back(c);
      }
      continue;
    }
    if (c == '"') {
      std::string before = field;
      trim(before);
      if (field_was_quoted || !before.empty())
        ThrowInputError("{}: line {}: a quote inside an unquoted field (quote the whole field and double the "
                        "quotes in it: \"a \"\"b\"\"\")",
                        name, line);
      field.clear();
      quoted = field_was_quoted = record_has_content = true;
    } else if (c == ',') {
      end_field();
      record_has_content = true;
    } else if (c == '\r' && i + 1 < text.size() && text[i + 1] == '\n') {
      // CRLF: the LF ends the record.
    } else if (c == '\n') {
      end_record();
      ++line;
    } else {
      if (field_was_quoted && c != ' ' && c != '\t')
        ThrowInputError("{}: line {}: text after a closing quote", name, line);
      if (!field_was_quoted) field.push_back(c);
      if (c != ' ' && c != '\t') record_has_content = true;
    }
  }
  if (quoted) ThrowInputError("{}: line {}: a quoted field is not closed", name, record.line);
  end_record();
  return records;
}

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

std::string CsvField(const std::string& s) {
  const bool needs = s.find_first_of(",\"\r\n") != std::string::npos ||
                     (!s.empty() && (s.front() == ' ' || s.back() == ' ' || s.front() == '\t' || s.back() == '\t'));
  if (!needs) return s;
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out.push_back('"');
    out.push_back(c);
  }
  return out + "\"";
}

std::vector<PairEntry> ReadPairsCsv(const std::filesystem::path& path) {
  const std::string name = path.string();
  const std::string expected = "expected a CSV with the columns id,left,right[,thickness]";
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) ThrowInputError("{}: is a folder ({})", name, expected);
  std::ifstream in(path, std::ios::binary);
  if (!in) ThrowInputError("{}: cannot open pairs file ({})", name, expected);
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::vector<Record> records = ParseCsv(buffer.str(), name);

  // Column order from the header, or the three columns of a file without one.
  std::vector<std::string> columns = {"id", "left", "right"};
  size_t first = 0;
  const auto known = [](const std::string& c) { return c == "id" || c == "left" || c == "right" || c == "thickness"; };
  const bool header = !records.empty() && (records[0].fields[0] == "id" ||
                                           std::all_of(records[0].fields.begin(), records[0].fields.end(), known));
  if (header) {
    columns = records[0].fields;
    first = 1;
    for (const std::string& c : columns)
      if (!known(c))
        ThrowInputError("{}: line 1: unknown column '{}' (the columns are id, left, right and optionally thickness)",
                        name, c);
    for (const char* required : {"id", "left", "right"})
      if (std::find(columns.begin(), columns.end(), required) == columns.end())
        ThrowInputError("{}: line 1: the header has no column '{}' ({})", name, required, expected);
  }
  const auto column = [&](const std::string& c) {
    return static_cast<int>(std::find(columns.begin(), columns.end(), c) - columns.begin());
  };
  const int id = column("id"), left = column("left"), right = column("right"), thickness = column("thickness");

  const std::filesystem::path base = path.parent_path();
  auto resolve = [&](const std::string& p) { return std::filesystem::path(p).is_absolute() ? p : (base / p).string(); };
  std::vector<PairEntry> out;
  for (size_t r = first; r < records.size(); ++r) {
    const Record& rec = records[r];
    if (rec.fields.size() != columns.size())
      ThrowInputError("{}: line {} has {} fields (expected {}: {})", name, rec.line, rec.fields.size(), columns.size(),
                      fmt::join(columns, ","));
    PairEntry e{rec.fields[id], rec.fields[left], rec.fields[right], std::nullopt};
    for (const auto& [value, what] : {std::pair{&e.id, "id"}, {&e.left, "left image"}, {&e.right, "right image"}})
      if (value->empty()) ThrowInputError("{}: line {}: the {} is empty", name, rec.line, what);
    if (thickness < static_cast<int>(columns.size()) && !rec.fields[thickness].empty())
      e.thickness_mm = ParseThickness(rec.fields[thickness], name, rec.line);
    e.left = resolve(e.left);
    e.right = resolve(e.right);
    out.push_back(std::move(e));
  }
  if (out.empty()) ThrowInputError("{}: no pairs listed ({})", name, expected);
  return out;
}

std::string PairsCsvText(const std::vector<PairEntry>& pairs) {
  bool with_thickness = false;
  for (const PairEntry& p : pairs) with_thickness |= p.thickness_mm.has_value();
  std::string text = with_thickness ? "id,left,right,thickness\n" : "id,left,right\n";
  for (const PairEntry& p : pairs) {
    text += fmt::format("{},{},{}", CsvField(p.id), CsvField(p.left), CsvField(p.right));
    if (with_thickness) text += p.thickness_mm ? fmt::format(",{}", *p.thickness_mm) : ",";
    text += "\n";
  }
  return text;
}

}  // namespace flatscan
