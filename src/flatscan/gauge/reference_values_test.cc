#include "flatscan/gauge/reference_values.h"

#include <cmath>
#include <fstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "flatscan/gauge/gauge_data.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

std::string Write(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
  return path.string();
}

TEST(ReferenceValues, ReadsValuesAndRefusesWhatIsWrong) {
  testing::ScratchDir dir("reference_values");
  const std::string ref = Write(dir.path() / "ref.csv", "part,minzone_mm,flatness_mm\np1,0.05,0.061\np2,0.02,0.03\n");
  const ReferenceTable table = ReadReferenceCsv(ref);
  ASSERT_EQ(table.size(), 2u);
  EXPECT_DOUBLE_EQ(*table.at("p1").Get(FlatnessQuantity::kFlatness), 0.061);
  EXPECT_DOUBLE_EQ(*table.at("p2").Get(FlatnessQuantity::kMinZone), 0.02);
  EXPECT_FALSE(table.at("p1").Get(FlatnessQuantity::kLsqPv).has_value());
  const auto error = [&](const std::string& text) {
    const std::string path = Write(dir.path() / "bad.csv", text);
    return testing::InputErrorOf([&] { ReadReferenceCsv(path); });
  };
  const std::string bad = (dir.path() / "bad.csv").string();
  EXPECT_EQ(error("part,flatness_mm\np1,0.05\np1,0.06\n"),
            bad + ": line 3: part 'p1' is listed twice (first on line 2): one reference value per part");
  EXPECT_EQ(error("part\np1\n"), bad + ": line 1: no value column (expected the columns part and flatness_mm, "
                                       "lsq_pv_mm and/or minzone_mm (mm))");
  EXPECT_EQ(error("part,flatness_mm\np1,-0.01\n"), bad + ": line 2: flatness_mm -0.01 is negative (a flatness is at "
                                                         "least 0)");
  EXPECT_EQ(error("part,flatnes_mm\n"), bad + ": line 1: unknown column 'flatnes_mm' (expected the columns part and "
                                              "flatness_mm, lsq_pv_mm and/or minzone_mm (mm))");
}

// A profiler's points of a part lying on its plate: a ridge 0.04 mm high along y = 0 on a
// plane tilted by 0.01 over the part (seated: one edge up). flatness_mm is the highest
// point above the plate; the minimum zone is the ridge's height above the tilted plane.
TEST(ReferenceValues, ComputesTheQuantitiesFromProfilerPoints) {
  testing::ScratchDir dir("reference_points");
  std::string text = "x,y,z\n";
  for (int i = 0; i <= 20; ++i)
    for (int j = -5; j <= 5; ++j) {
      const double x = i, y = j, ridge = j == 0 ? 0.04 : 0.0;
      text += fmt::format("{},{},{}\n", x, y, 0.0005 * x + ridge);
    }
  Write(dir.path() / "p7.csv", text);
  Write(dir.path() / "notes.txt", "not points");
  const ReferenceTable table = ReadReferencePoints(dir.path());
  ASSERT_EQ(table.size(), 1u);
  const ReferenceValue& v = table.at("p7");
  EXPECT_NEAR(*v.flatness_mm, 0.01 + 0.04, 1e-12);
  EXPECT_NEAR(*v.minzone_mm, 0.04 / std::sqrt(1 + 0.0005 * 0.0005), 1e-9);
  EXPECT_GT(*v.lsq_pv_mm, 0.035);
  Write(dir.path() / "short.csv", "x,y,z\n0,0,0\n1,0,0\n");
  EXPECT_EQ(testing::InputErrorOf([&] { ReadReferencePoints(dir.path()); }),
            (dir.path() / "short.csv").string() + ": 2 points: the flatness of a part needs at least 3 (x,y,z in mm)");
}

TEST(ReferenceValues, PairingNamesUnknownPartsAndUnitMistakes) {
  ReferenceTable reference;
  for (int i = 1; i <= 6; ++i) reference[fmt::format("p{}", i)].flatness_mm = 0.02 * i;
  std::vector<GaugeObservation> measured;
  for (int i = 1; i <= 6; ++i)
    for (int t = 1; t <= 2; ++t) measured.push_back({fmt::format("p{}", i), "", std::to_string(t), 0.02 * i + 0.001 * t, 0});
  const std::vector<AgreementPair> pairs =
      PairWithReference(measured, reference, FlatnessQuantity::kFlatness, "data.csv", "ref.csv");
  ASSERT_EQ(pairs.size(), 6u);
  EXPECT_NEAR(pairs[0].measured, 0.02 + 0.0015, 1e-12);  // the mean of the two trials
  EXPECT_EQ(pairs[0].trials, 2);

  std::vector<GaugeObservation> typo = measured;
  typo[3].part = "P2";
  EXPECT_EQ(testing::InputErrorOf([&] { PairWithReference(typo, reference, FlatnessQuantity::kFlatness, "data.csv", "ref.csv"); }),
            "data.csv: unknown part ids 'P2': not in the reference ref.csv (a typo, or the wrong file?)");
  ReferenceTable more = reference;
  more["p9"].flatness_mm = 0.05;
  EXPECT_EQ(testing::InputErrorOf([&] { PairWithReference(measured, more, FlatnessQuantity::kFlatness, "data.csv", "ref.csv"); }),
            "ref.csv: part ids 'p9' were not measured in data.csv (a typo, or the wrong file?)");
  EXPECT_EQ(testing::InputErrorOf([&] { PairWithReference(measured, reference, FlatnessQuantity::kMinZone, "data.csv", "ref.csv"); }),
            "ref.csv: part 'p1' has no minzone_mm (the study compares minzone_mm)");
  ReferenceTable um = reference;
  for (auto& [part, v] : um) v.flatness_mm = 1000 * *v.flatness_mm;
  EXPECT_EQ(testing::InputErrorOf([&] { PairWithReference(measured, um, FlatnessQuantity::kFlatness, "data.csv", "ref.csv"); }),
            "ref.csv (median 70) and data.csv (median 0.0715) are 979 times apart: one of them is in micrometres? "
            "(both must be in mm)");
}

}  // namespace
}  // namespace flatscan
