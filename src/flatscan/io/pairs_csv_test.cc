#include "flatscan/io/pairs_csv.h"

#include <fstream>

#include <gtest/gtest.h>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

TEST(PairsCsv, WrittenTextReadsBackWithPathsResolvedAgainstItsFolder) {
  testing::ScratchDir dir("pairs-csv");
  const std::vector<PairEntry> pairs = {{"a", "parts/a_left.png", "parts/a_right.png", std::nullopt, {}},
                                        {"b", "/abs/l.png", "/abs/r.png", std::nullopt, {}}};
  const std::string text = PairsCsvText(pairs);
  EXPECT_EQ(text, "id,left,right\na,parts/a_left.png,parts/a_right.png\nb,/abs/l.png,/abs/r.png\n");
  std::ofstream(dir.path() / "pairs.csv") << text;
  const std::vector<PairEntry> back = ReadPairsCsv(dir.path() / "pairs.csv");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].id, "a");
  EXPECT_EQ(back[0].left, (dir.path() / "parts/a_left.png").string());
  EXPECT_EQ(back[1].right, "/abs/r.png");
  EXPECT_FALSE(back[0].thickness_mm.has_value());
}

TEST(PairsCsv, StudyTagsRoundTrip) {
  testing::ScratchDir dir("pairs-csv-study");
  const std::vector<PairEntry> pairs = {{"p1_t1", "a_l.png", "a_r.png", std::nullopt, {"p1", "A", "1"}},
                                        {"extra", "b_l.png", "b_r.png", std::nullopt, {}}};
  const std::string text = PairsCsvText(pairs);
  EXPECT_EQ(text, "id,left,right,part,appraiser,trial\np1_t1,a_l.png,a_r.png,p1,A,1\nextra,b_l.png,b_r.png,,,\n");
  std::ofstream(dir.path() / "pairs.csv") << text;
  const std::vector<PairEntry> back = ReadPairsCsv(dir.path() / "pairs.csv");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].study, (StudyTags{"p1", "A", "1"}));
  EXPECT_TRUE(back[1].study.Empty());
}

// Before: quoted fields, a BOM and padding broke the reader, and a batch of parts of
// different thickness was measured with one --thickness (68 um error for 0.1 mm).
TEST(PairsCsv, FollowsRfc4180WithAThicknessColumn) {
  testing::ScratchDir dir("pairs-csv-rfc");
  const std::vector<PairEntry> pairs = {{"a, \"b\"", "with,comma.png", " padded .png", 0.2862158275389911, {}},
                                        {"c", "c_l.png", "c_r.png", std::nullopt, {}}};
  const std::string text = PairsCsvText(pairs);
  EXPECT_EQ(text, "id,left,right,thickness\n\"a, \"\"b\"\"\",\"with,comma.png\",\" padded .png\",0.2862158275389911\n"
                  "c,c_l.png,c_r.png,\n");
  std::ofstream(dir.path() / "p.csv") << text;
  const std::vector<PairEntry> back = ReadPairsCsv(dir.path() / "p.csv");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].id, "a, \"b\"");
  EXPECT_EQ(back[0].left, (dir.path() / "with,comma.png").string());
  EXPECT_EQ(back[0].right, (dir.path() / " padded .png").string());
  EXPECT_EQ(back[0].thickness_mm, 0.2862158275389911);
  EXPECT_FALSE(back[1].thickness_mm.has_value());
  // A spreadsheet's export: BOM, CRLF, padding, columns in another order, a quoted line break.
  std::ofstream(dir.path() / "excel.csv") << "\xEF\xBB\xBFthickness , id,left,right\r\n"
                                          << " 0.15 , p1 , l1.png , r1.png \r\n"
                                          << "\r\n"
                                          << "0.3,\"p\n2\",l2.png,r2.png\r\n";
  const std::vector<PairEntry> excel = ReadPairsCsv(dir.path() / "excel.csv");
  ASSERT_EQ(excel.size(), 2u);
  EXPECT_EQ(excel[0].id, "p1");
  EXPECT_EQ(excel[0].left, (dir.path() / "l1.png").string());
  EXPECT_EQ(excel[0].thickness_mm, 0.15);
  EXPECT_EQ(excel[1].id, "p\n2");
  EXPECT_EQ(excel[1].thickness_mm, 0.3);
}

TEST(PairsCsv, BadFilesNameTheFileAndLine) {
  testing::ScratchDir dir("pairs-csv-bad");
  const auto path = dir.path() / "p.csv";
  const std::string p = path.string();
  const auto error = [&](const std::string& text) {
    std::ofstream(path, std::ios::trunc) << text;
    return testing::InputErrorOf([&] { ReadPairsCsv(path); });
  };
  EXPECT_EQ(testing::InputErrorOf([&] { ReadPairsCsv(path); }),
            p + ": cannot open pairs file (expected a CSV with the columns id,left,right[,thickness][,part,appraiser,trial])");
  EXPECT_EQ(testing::InputErrorOf([&] { ReadPairsCsv(dir.path()); }),
            dir.path().string() + ": is a folder (expected a CSV with the columns id,left,right[,thickness][,part,appraiser,trial])");
  EXPECT_EQ(error("id,left,right\r\na,l.png,r.png\r\nb,l.png\n"), p + ": line 3 has 2 fields (expected 3: id,left,right)");
  EXPECT_EQ(error("id,left,right\n\n"), p + ": no pairs listed (expected a CSV with the columns id,left,right[,thickness][,part,appraiser,trial])");
  EXPECT_EQ(error("id,left,right\np0,,\n"), p + ": line 2: the left image is empty");  // was "has 2 columns"
  EXPECT_EQ(error("id,left,right,thicknes\na,l,r,0.2\n"),
            p + ": line 1: unknown column 'thicknes' (the columns are id, left, right and optionally thickness, "
                "part, appraiser, trial)");
  EXPECT_EQ(error("id,left,right,thickness\na,l,r,0.2mm\n"),
            p + ": line 2: thickness '0.2mm' must be a number of mm in [0, 5]");
  EXPECT_EQ(error("id,left,right,thickness\na,l,r,nan\n"), p + ": line 2: thickness 'nan' must be a number of mm in [0, 5]");
  EXPECT_EQ(error("id,left,right\na,\"l.png,r.png\n"), p + ": line 2: a quoted field is not closed");
  EXPECT_EQ(error("id,left,right\na,l\"x\".png,r.png\n"),
            p + ": line 2: a quote inside an unquoted field (quote the whole field and double the quotes in it: "
                "\"a \"\"b\"\"\")");
  EXPECT_EQ(error("id,left,right\na,\"l.png\"x,r.png\n"), p + ": line 2: text after a closing quote");
}

}  // namespace
}  // namespace flatscan
