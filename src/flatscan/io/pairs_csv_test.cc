#include "flatscan/io/pairs_csv.h"

#include <fstream>

#include <gtest/gtest.h>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

TEST(PairsCsv, WrittenTextReadsBackWithPathsResolvedAgainstItsFolder) {
  testing::ScratchDir dir("pairs-csv");
  const std::vector<PairEntry> pairs = {{"a", "parts/a_left.png", "parts/a_right.png"}, {"b", "/abs/l.png", "/abs/r.png"}};
  const std::string text = PairsCsvText(pairs);
  EXPECT_EQ(text, "id,left,right\na,parts/a_left.png,parts/a_right.png\nb,/abs/l.png,/abs/r.png\n");
  std::ofstream(dir.path() / "pairs.csv") << text;
  const std::vector<PairEntry> back = ReadPairsCsv(dir.path() / "pairs.csv");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].id, "a");
  EXPECT_EQ(back[0].left, (dir.path() / "parts/a_left.png").string());
  EXPECT_EQ(back[1].right, "/abs/r.png");
}

TEST(PairsCsv, BadFilesNameTheFileAndLine) {
  testing::ScratchDir dir("pairs-csv-bad");
  const auto path = dir.path() / "p.csv";
  EXPECT_EQ(testing::InputErrorOf([&] { ReadPairsCsv(path); }),
            path.string() + ": cannot open pairs file (expected a CSV with columns id,left,right)");
  std::ofstream(path) << "id,left,right\r\na,l.png,r.png\r\nb,l.png\n";
  EXPECT_EQ(testing::InputErrorOf([&] { ReadPairsCsv(path); }),
            path.string() + ": line 3 has 2 columns (expected 3: id,left,right)");
  std::ofstream(path) << "id,left,right\n\n";
  EXPECT_EQ(testing::InputErrorOf([&] { ReadPairsCsv(path); }),
            path.string() + ": no pairs listed (expected lines id,left,right)");
}

}  // namespace
}  // namespace flatscan
