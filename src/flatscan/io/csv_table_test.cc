#include "flatscan/io/csv_table.h"

#include <fstream>

#include <gtest/gtest.h>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

std::string Write(const testing::ScratchDir& dir, const std::string& text) {
  const std::string path = (dir.path() / "t.csv").string();
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

TEST(CsvTable, ReadsColumnsInAnyOrderAndNamesWhatIsWrong) {
  testing::ScratchDir dir("csv_table");
  const std::vector<std::string> required = {"part", "value"}, optional = {"trial"};
  std::string path = Write(dir, "\xEF\xBB\xBFvalue, part\r\n0.05,\"a, b\"\r\n\r\n1e-2,c\n");
  const CsvTable table = CsvTable::Read(path, required, optional, "part,value");
  ASSERT_EQ(table.rows(), 2u);
  EXPECT_EQ(table.Cell(0, "part"), "a, b");
  EXPECT_DOUBLE_EQ(table.Number(1, "value"), 0.01);
  EXPECT_EQ(table.Line(1), 4);
  EXPECT_FALSE(table.Has("trial"));
  EXPECT_EQ(table.Cell(0, "trial"), "");

  const auto error = [&](const std::string& text) {
    const std::string p = Write(dir, text);
    return testing::InputErrorOf([&] { CsvTable::Read(p, required, optional, "part,value"); });
  };
  EXPECT_EQ(error("part,value,vlaue\n"), path + ": line 1: unknown column 'vlaue' (expected part,value)");
  EXPECT_EQ(error("part,part,value\n"), path + ": line 1: the column 'part' is named twice");
  EXPECT_EQ(error("part,trial\n"), path + ": line 1: the header has no column 'value' (expected part,value)");
  EXPECT_EQ(error("part,value\na,1\nb\n"), path + ": line 3 has 1 fields (expected 2: part,value)");
  EXPECT_EQ(error(""), path + ": empty (expected a CSV with part,value)");
  const std::string p = Write(dir, "part,value\na,0.1mm\n");
  EXPECT_EQ(testing::InputErrorOf([&] { CsvTable::Read(p, required, optional, "x").Number(0, "value"); }),
            path + ": line 2: value '0.1mm' is not a number");
  EXPECT_EQ(testing::InputErrorOf([&] { CsvTable::Read(dir.path() / "none.csv", required, optional, "part,value"); }),
            (dir.path() / "none.csv").string() + ": cannot open (expected a CSV with part,value)");
}

}  // namespace
}  // namespace flatscan
