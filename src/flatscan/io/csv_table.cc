#include "flatscan/io/csv_table.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "flatscan/util/error.h"

namespace flatscan {

std::vector<CsvRecord> ParseCsv(std::string_view text, const std::string& name) {
  if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
  std::vector<CsvRecord> records;
  CsvRecord record;
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
    record = CsvRecord{};
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

CsvTable CsvTable::Read(const std::filesystem::path& path, const std::vector<std::string>& required,
                        const std::vector<std::string>& optional, const std::string& expected) {
  CsvTable table;
  table.file_ = path.string();
  const std::string& name = table.file_;
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) ThrowInputError("{}: is a folder (expected a CSV with {})", name, expected);
  std::ifstream in(path, std::ios::binary);
  if (!in) ThrowInputError("{}: cannot open (expected a CSV with {})", name, expected);
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::vector<CsvRecord> records = ParseCsv(buffer.str(), name);
  if (records.empty()) ThrowInputError("{}: empty (expected a CSV with {})", name, expected);

  table.columns_ = records[0].fields;
  const auto listed = [](const std::vector<std::string>& list, const std::string& c) {
    return std::find(list.begin(), list.end(), c) != list.end();
  };
  for (const std::string& c : table.columns_) {
    if (!listed(required, c) && !listed(optional, c))
      ThrowInputError("{}: line {}: unknown column '{}' (expected {})", name, records[0].line, c, expected);
    if (std::count(table.columns_.begin(), table.columns_.end(), c) > 1)
      ThrowInputError("{}: line {}: the column '{}' is named twice", name, records[0].line, c);
  }
  for (const std::string& c : required)
    if (!listed(table.columns_, c))
      ThrowInputError("{}: line {}: the header has no column '{}' (expected {})", name, records[0].line, c, expected);
  for (size_t r = 1; r < records.size(); ++r)
    if (records[r].fields.size() != table.columns_.size())
      ThrowInputError("{}: line {} has {} fields (expected {}: {})", name, records[r].line, records[r].fields.size(),
                      table.columns_.size(), fmt::join(table.columns_, ","));
  table.rows_.assign(std::make_move_iterator(records.begin() + 1), std::make_move_iterator(records.end()));
  return table;
}

bool CsvTable::Has(const std::string& column) const {
  return std::find(columns_.begin(), columns_.end(), column) != columns_.end();
}

const std::string& CsvTable::Cell(size_t row, const std::string& column) const {
  static const std::string kEmpty;
  const auto it = std::find(columns_.begin(), columns_.end(), column);
  return it == columns_.end() ? kEmpty : rows_[row].fields[it - columns_.begin()];
}

double CsvTable::Number(size_t row, const std::string& column) const {
  const std::string& text = Cell(row, column);
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || error != std::errc() || end != text.data() + text.size() || !std::isfinite(value))
    ThrowInputError("{}: line {}: {} '{}' is not a number", file_, Line(row), column, text);
  return value;
}

}  // namespace flatscan
