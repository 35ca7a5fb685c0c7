#include "flatscan/gauge/gauge_data.h"

#include <fstream>

#include <gtest/gtest.h>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

std::string Write(const testing::ScratchDir& dir, const std::string& name, const std::string& text) {
  const std::string path = (dir.path() / name).string();
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

TEST(GaugeData, ReadsTheThreeStudiesColumns) {
  testing::ScratchDir dir("gauge_data");
  const std::string grr = Write(dir, "grr.csv", "part,trial,value\n7,1,0.081\n07,2,0.082\n");
  const std::vector<GaugeObservation> g = ReadGaugeRRCsv(grr);
  ASSERT_EQ(g.size(), 2u);
  EXPECT_EQ(g[0].appraiser, "station");  // no appraiser column: one station
  EXPECT_EQ(g[1].part, "07");            // labels are text
  EXPECT_EQ(g[1].line, 3);
  EXPECT_DOUBLE_EQ(g[1].value, 0.082);
  EXPECT_EQ(testing::InputErrorOf([&] { ReadGaugeRRCsv(Write(dir, "e.csv", "part,appraiser,trial,value\n1,,1,0.1\n")); }),
            (dir.path() / "e.csv").string() + ": line 2: the appraiser is empty");

  const std::string t1 = Write(dir, "t1.csv", "trial,part,value\n1,ref,0.0812\n2,ref,0.0815\n");
  EXPECT_EQ(ReadType1Csv(t1), (std::vector<double>{0.0812, 0.0815}));
  const std::string two = Write(dir, "t2.csv", "part,value\nref,0.0812\nother,0.0815\n");
  EXPECT_EQ(testing::InputErrorOf([&] { ReadType1Csv(two); }),
            two + ": line 3: part 'other', but line 2 is part 'ref': a type 1 study measures one reference part");

  const std::string lin = Write(dir, "lin.csv", "part,reference,value\na,0.02,0.021\nb,0.05,0.049\n");
  ASSERT_EQ(ReadLinearityCsv(lin).size(), 2u);
  const std::string um = Write(dir, "lin_um.csv", "part,reference,value\na,0.02,21\nb,0.05,49\n");
  EXPECT_EQ(testing::InputErrorOf([&] { ReadLinearityCsv(um); }),
            um + ": the values (median 35) and the references (median 0.035) are 1000 times apart: one column is in "
                 "micrometres? (both must be in mm)");
}

TEST(GaugeData, ValuesInMicrometresAreRefused) {
  const std::vector<double> mm = {0.081, 0.094, 0.12, 0.05};
  CheckMillimetres(mm, 0.1, "grr.csv");  // no error
  const std::vector<double> um = {81, 94, 120, 50};
  EXPECT_EQ(testing::InputErrorOf([&] { CheckMillimetres(um, 0.1, "grr.csv"); }),
            "grr.csv: the values look like micrometres: their median 87.5 is 875 times the tolerance 0.1 mm (expected "
            "values in mm: divide by 1000)");
}

}  // namespace
}  // namespace flatscan
