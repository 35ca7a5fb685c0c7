// `flatscan report` on a real SQLite store.
#include <filesystem>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "flatscan/store/results_store.h"
#include "flatscan/store/store_test_util.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {
namespace fs = std::filesystem;

TEST(ReportCommand, WritesTheReportOfAStoreAndNamesWhatItCannotUse) {
  testing::ScratchDir dir("report");
  const std::string store_path = (dir.path() / "results.db").string();
  {
    const auto store = OpenSqliteStore(store_path, true);
    int k = 0;
    for (const double flatness : {0.04, 0.05, -1.0, 0.045, 0.12}) {
      ++k;
      StationRecord r = testing::TestRecord(fmt::format("p{}", k), std::string(64, char('a' + k)), flatness);
      ASSERT_TRUE(store->Commit(r));
    }
  }
  const fs::path html = dir.path() / "report.html";
  auto r = testing::RunFlatscan(fmt::format("report --store {} -o {}", store_path, html.string()), 60);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, fmt::format("wrote {}: 5 records, 4 measured, yield 75.0%\n", html.string()));
  const std::string text = testing::ReadFileBytes(html);
  EXPECT_NE(text.find("<h2>Recipe shield</h2>"), std::string::npos);
  EXPECT_NE(text.find(fmt::format("flatscan report --store {}", store_path)), std::string::npos);

  r = testing::RunFlatscan(fmt::format("report --store {} --recipe-name lid -o {}/none.html", store_path,
                                       dir.path().string()));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(fmt::format("--store '{}': no records of recipe 'lid' (nothing to report)", store_path)),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(dir.path() / "none.html"));
  r = testing::RunFlatscan(fmt::format("report --store {} --from 2999-01-01 -o {}/none.html", store_path,
                                       dir.path().string()));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("no records from 2999-01-01 to the end (nothing to report)"), std::string::npos) << r.err;
  r = testing::RunFlatscan(fmt::format("report --store {}/missing.db -o {}/none.html", dir.path().string(),
                                       dir.path().string()));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("missing.db': no such results store"), std::string::npos) << r.err;
  r = testing::RunFlatscan(fmt::format("report --store {0} -o {0}", store_path));  // onto its own input
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("is the input of --store"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace flatscan
