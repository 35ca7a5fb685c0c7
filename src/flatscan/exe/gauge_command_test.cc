// `flatscan gauge grr|type1|linearity` on data files: the worked examples through the
// command, the JSON keys external tools read, and bad data refused with exit 2.
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "flatscan/gauge/gauge_test_util.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {
namespace fs = std::filesystem;

TEST(GaugeCommand, GrrOfTheAiagExampleWritesItsJsonAndHtml) {
  testing::ScratchDir dir("gauge_grr");
  const fs::path data = dir.path() / "grr.csv", json = dir.path() / "grr.json", html = dir.path() / "grr.html";
  testing::WriteGaugeRRCsv(data, testing::AiagGaugeRRExample());
  const auto r = testing::RunFlatscan(
      fmt::format("gauge grr --data {} --tolerance 5 --json {} --html {}", data.string(), json.string(), html.string()),
      60);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("**%GRR of the tolerance 36.3%: not acceptable**; %GRR of TV 27.9%; ndc 4"), std::string::npos)
      << r.out;
  const nlohmann::json j = nlohmann::json::parse(testing::ReadFileBytes(json));
  for (const char* key : {"ev", "av", "interaction", "grr", "pv", "tv", "pct_grr_tolerance", "pct_grr_tv", "ndc",
                          "method", "interaction_included"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_NEAR(j["grr"].get<double>(), 0.302372, 1e-6);
  EXPECT_EQ(j["ndc"], 4);
  EXPECT_EQ(j["interaction_included"], false);
  const std::string page = testing::ReadFileBytes(html);
  EXPECT_NE(page.find("<td>parts x appraisers</td>"), std::string::npos);
}

TEST(GaugeCommand, BadDataIsRefusedWithoutWritingAStudy) {
  testing::ScratchDir dir("gauge_bad");
  const fs::path json = dir.path() / "out.json";
  std::vector<GaugeObservation> data = testing::AiagGaugeRRExample();
  for (GaugeObservation& o : data) o.value = 1000 * (0.08 + 0.01 * o.value);  // micrometres
  const fs::path um = dir.path() / "um.csv";
  testing::WriteGaugeRRCsv(um, data);
  auto r = testing::RunFlatscan(fmt::format("gauge grr --data {} --tolerance 0.1 --json {}", um.string(), json.string()));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(fmt::format("{}: the values look like micrometres: their median 80.15 is", um.string())),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("times the tolerance 0.1 mm (expected values in mm: divide by 1000)"), std::string::npos);
  EXPECT_FALSE(fs::exists(json));
  EXPECT_EQ(r.out, "");

  data = testing::AiagGaugeRRExample();
  data.erase(data.begin() + 5);  // part 6, appraiser A, trial 1 missing
  const fs::path unbalanced = dir.path() / "unbalanced.csv";
  testing::WriteGaugeRRCsv(unbalanced, data);
  r = testing::RunFlatscan(fmt::format("gauge grr --data {} --tolerance 5", unbalanced.string()));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unbalanced design: part '6' by appraiser 'A' has 2 trials"), std::string::npos) << r.err;

  r = testing::RunFlatscan(fmt::format("gauge grr --data {} --tolerance -1", unbalanced.string()));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--tolerance: expected a tolerance above 0 mm, got -1"), std::string::npos) << r.err;
}

TEST(GaugeCommand, Type1AndLinearityRunFromTheirFiles) {
  testing::ScratchDir dir("gauge_t1");
  const fs::path t1 = dir.path() / "t1.csv", lin = dir.path() / "lin.csv", json = dir.path() / "t1.json";
  {
    std::ofstream out(t1);
    out << "trial,value\n";
    for (int i = 0; i < 25; ++i) out << fmt::format("{},{}\n", i + 1, i < 12 ? 0.101 : i < 24 ? 0.099 : 0.100);
    std::ofstream l(lin);
    l << "part,reference,value\n";
    for (const LinearityObservation& o : testing::AiagLinearityExample())
      l << fmt::format("{},{},{}\n", o.part, o.reference, o.value);
  }
  auto r = testing::RunFlatscan(
      fmt::format("gauge type1 --data {} --tolerance 0.1 --reference 0.0995 --json {}", t1.string(), json.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(testing::ReadFileBytes(json));
  EXPECT_NEAR(j["cg"].get<double>(), 3.3333, 1e-4);
  EXPECT_NEAR(j["cgk"].get<double>(), 3.1667, 1e-4);
  EXPECT_EQ(j["capable"], true);
  EXPECT_NE(r.out.find("**capable** (Cg and Cgk at least 1.33)"), std::string::npos) << r.out;

  r = testing::RunFlatscan(fmt::format("gauge linearity --data {}", lin.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;  // the study ran; its verdict is in the output
  EXPECT_NE(r.out.find("bias = 0.736667 + -0.131667 x reference (mm)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("**not acceptable**: the line bias = 0 leaves the 95% confidence band"), std::string::npos);
}

TEST(GaugeCommand, AgreementWithAReferenceCsvAndItsPoints) {
  testing::ScratchDir dir("gauge_agreement");
  const fs::path ref = dir.path() / "ref.csv", data = dir.path() / "data.csv", json = dir.path() / "a.json",
                 html = dir.path() / "a.html", points = dir.path() / "points";
  fs::create_directory(points);
  {
    std::ofstream r(ref), d(data);
    r << "part,flatness_mm\n";
    d << "part,trial,value\n";
    for (int i = 1; i <= 6; ++i) {
      r << fmt::format("p{},{}\n", i, 0.02 * i);
      // flatscan reads 2 um high on average, +-1 um between its two trials.
      d << fmt::format("p{},1,{}\np{},2,{}\n", i, 0.02 * i + 0.001 + 0.0005 * (i % 2), i, 0.02 * i + 0.003);
      // The same parts as profiler points: a flat sheet tilted so that one end stands 0.02 i up.
      std::ofstream p(points / fmt::format("p{}.csv", i));
      p << "x,y,z\n";
      for (int x = 0; x <= 10; ++x)
        for (int y = 0; y <= 4; ++y) p << fmt::format("{},{},{}\n", x, y, 0.002 * i * x);
    }
  }
  auto r = testing::RunFlatscan(fmt::format("gauge agreement --data {} --reference {} --tolerance 0.1 --json {} --html {}",
                                            data.string(), ref.string(), json.string(), html.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  nlohmann::json j = nlohmann::json::parse(testing::ReadFileBytes(json));
  EXPECT_EQ(j["n"], 6);
  // Mean differences 2.25 um (odd parts: (1.5 + 3) / 2) and 2 um (even parts): bias 2.125 um.
  EXPECT_NEAR(j["bias_mm"].get<double>(), 0.002125, 1e-9);
  EXPECT_NEAR(j["pearson_r"].get<double>(), 1.0, 1e-3);
  EXPECT_NE(testing::ReadFileBytes(html).find("<svg"), std::string::npos);

  // The points give the same reference (flatness_mm = the raised end, 0.02 i).
  r = testing::RunFlatscan(fmt::format("gauge agreement --data {} --reference-points {} --tolerance 0.1 --json {}",
                                       data.string(), points.string(), json.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  j = nlohmann::json::parse(testing::ReadFileBytes(json));
  EXPECT_NEAR(j["bias_mm"].get<double>(), 0.002125, 1e-9);

  // A reference part nobody measured: exit 2, the earlier JSON left as it was.
  std::ofstream(ref, std::ios::app) << "p7,0.05\n";
  const std::string before = testing::ReadFileBytes(json);
  r = testing::RunFlatscan(fmt::format("gauge agreement --data {} --reference {} --tolerance 0.1 --json {}",
                                       data.string(), ref.string(), json.string()));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(fmt::format("{}: part ids 'p7' were not measured in {}", ref.string(), data.string())),
            std::string::npos)
      << r.err;
  EXPECT_EQ(testing::ReadFileBytes(json), before);
}

// The whole path: a simulated dataset with repeated shots, listed in a pairs file that tags
// each shot as a trial of its part, replayed by a station into its results store, studied
// from the store; the same values exported and studied from a CSV give the same study.
TEST(GaugeCommand, GrrFromAStationsTaggedRecords) {
  testing::ScratchDir dir("gauge_store");
  const fs::path data = dir.path() / "data", store = dir.path() / "results.db";
  auto r = testing::RunFlatscan(fmt::format("simulate --preset compact --parts 5 --shots 2 --no-calibration "
                                            "--no-markers --seed 4 -q -o {}",
                                            data.string()),
                                120);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ofstream(data / "shield.yml") << "name: shield\nthickness_mm: 0.2\ntolerance_mm: 0.25\nrig: rig.yml\n"
                                        "plane: plane_true.yml\n";
  {
    std::ofstream tagged(data / "study.csv");
    tagged << "id,left,right,part,trial\n";
    for (int part = 0; part < 5; ++part)
      for (int shot = 0; shot < 2; ++shot)
        tagged << fmt::format("part_{0:03d}_shot_{1:02d},parts/part_{0:03d}_shot_{1:02d}_left.png,"
                              "parts/part_{0:03d}_shot_{1:02d}_right.png,part_{0:03d},{2}\n",
                              part, shot, shot + 1);
  }
  r = testing::RunFlatscan(fmt::format("station --recipe {} --source pairs:{} --store {} --station-id st-1 "
                                       "--until-idle 0.2",
                                       (data / "shield.yml").string(), (data / "study.csv").string(), store.string()),
                           120);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const fs::path from_store = dir.path() / "store.json", from_csv = dir.path() / "csv.json", csv = dir.path() / "grr.csv";
  r = testing::RunFlatscan(
      fmt::format("gauge grr --store {} --tolerance 0.25 --json {}", store.string(), from_store.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("5 parts x 1 appraiser x 2 trials"), std::string::npos) << r.out;

  r = testing::RunFlatscan(fmt::format("results --store {} --json", store.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  {
    std::ofstream out(csv);
    out << "part,appraiser,trial,value\n";
    std::istringstream lines(r.out);
    for (std::string line; std::getline(lines, line);) {
      const nlohmann::json j = nlohmann::json::parse(line);
      EXPECT_EQ(j["study"]["trial"], j["source_id"].get<std::string>().back() == '0' ? "1" : "2");
      out << fmt::format("{},{},{},{}\n", j["study"]["part"].get<std::string>(), j["station_id"].get<std::string>(),
                         j["study"]["trial"].get<std::string>(), j["flatness_mm"].get<double>());
    }
  }
  r = testing::RunFlatscan(fmt::format("gauge grr --data {} --tolerance 0.25 --json {}", csv.string(), from_csv.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json a = nlohmann::json::parse(testing::ReadFileBytes(from_store)),
                       b = nlohmann::json::parse(testing::ReadFileBytes(from_csv));
  for (const char* key : {"ev", "pv", "grr", "ndc"}) EXPECT_EQ(a[key], b[key]) << key;
  EXPECT_LT(a["grr"].get<double>(), 0.003);  // true rig and plane, compact: micrometres

  // A type 1 study reads one part: the store holds five, so it asks for --part, which
  // chooses one (two values here: too few for a type 1 study, which says how many).
  r = testing::RunFlatscan(fmt::format("gauge type1 --store {} --tolerance 0.25 --reference 0.05", store.string()));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("records of part 'part_000' and of part 'part_001': a type 1 study measures one reference part "
                       "(choose it with --part)"),
            std::string::npos)
      << r.err;
  r = testing::RunFlatscan(fmt::format("gauge type1 --store {} --part part_003 --tolerance 0.25 --reference 0.05", store.string()));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("results.db: 2 values: a type 1 study needs at least 25 measurements of the reference part"),
            std::string::npos)
      << r.err;
  r = testing::RunFlatscan(fmt::format("gauge type1 --store {} --part part_9 --tolerance 0.25 --reference 0.05", store.string()));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(fmt::format("--part 'part_9': {} has no value of that part", store.string())), std::string::npos)
      << r.err;

  // A tagged pair that could not be measured: the study is refused, naming it.
  std::ofstream(data / "study.csv", std::ios::app) << "lost,parts/none_left.png,parts/none_right.png,part_000,3\n";
  r = testing::RunFlatscan(fmt::format("station --recipe {} --source pairs:{} --store {} --station-id st-1 "
                                       "--until-idle 0.2",
                                       (data / "shield.yml").string(), (data / "study.csv").string(), store.string()),
                           120);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = testing::RunFlatscan(fmt::format("gauge grr --store {} --tolerance 0.25", store.string()));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(fmt::format("--store '{}': record 11 (part 'part_000', appraiser 'st-1', trial '3') was not "
                                   "measured: ",
                                   store.string())),
            std::string::npos)
      << r.err;
}

}  // namespace
}  // namespace flatscan
