#pragma once
// CSV files (RFC 4180) with a header naming their columns: the pairs files and the gauge
// studies' data read them the same way.
//
// Reading: fields may be quoted ("a, b" and "a ""quoted"" name", also across lines); a
// UTF-8 byte-order mark and CRLF line ends are accepted; spaces and tabs around unquoted
// fields are trimmed; blank lines are skipped. Errors throw InputError naming the file and
// the line.
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace flatscan {

// One record: its fields and the line it starts on (1-based).
struct CsvRecord {
  std::vector<std::string> fields;
  int line = 0;
};

// The records of `text`; `name` (the file) is used in error messages. Written here rather
// than taken from a library (Debian's libcsv is a callback C API): it is short, and the
// errors must name the file and line as every reader of ours does.
std::vector<CsvRecord> ParseCsv(std::string_view text, const std::string& name);

// One CSV field, quoted where RFC 4180 needs it: a comma, a quote (doubled inside the
// quotes), a line end, or a space or tab at an end (which a reader would trim).
std::string CsvField(const std::string& s);

// A CSV whose first record names its columns, which may come in any order. Every
// required column must be there; a column that is neither required nor optional is
// refused (a misspelt optional column would silently be ignored); every record has
// as many fields as the header.
class CsvTable {
 public:
  // `expected` describes the file for error messages ("the columns part,appraiser,trial,value").
  static CsvTable Read(const std::filesystem::path& path, const std::vector<std::string>& required,
                       const std::vector<std::string>& optional, const std::string& expected);

  const std::string& file() const { return file_; }
  size_t rows() const { return rows_.size(); }
  bool Has(const std::string& column) const;
  // The cell of data row `row` (0-based, after the header) in `column`; "" for an absent optional column.
  const std::string& Cell(size_t row, const std::string& column) const;
  int Line(size_t row) const { return rows_[row].line; }
  // The cell as a finite number; throws InputError "<file>: line N: <column> 'x' is not a number".
  double Number(size_t row, const std::string& column) const;

 private:
  std::string file_;
  std::vector<std::string> columns_;
  std::vector<CsvRecord> rows_;
};

}  // namespace flatscan
