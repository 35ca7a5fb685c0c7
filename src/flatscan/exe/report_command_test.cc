// `flatscan report` on a real SQLite store.
#include <cstdlib>
#include <filesystem>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "flatscan/report/pdf_printer.h"
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

// A store of two recipes: five "shield" parts (one not measured), three "lid" parts.
std::string TwoRecipeStore(const testing::ScratchDir& dir) {
  const std::string path = (dir.path() / "results.db").string();
  const auto store = OpenSqliteStore(path, true);
  int k = 0;
  for (const double flatness : {0.04, 0.05, -1.0, 0.045, 0.12, 0.02, 0.03, 0.025}) {
    ++k;
    StationRecord r = testing::TestRecord(fmt::format("p{}", k), std::string(64, 'a'), flatness);
    if (k > 5) r.recipe_name = "lid";
    EXPECT_TRUE(store->Commit(r));
  }
  return path;
}

// --pdf prints the report through headless Chromium: a page of summary, then each recipe
// from the top of a page (it fits on one here). With FLATSCAN_SCREENSHOTS=DIR the test
// leaves a screenshot of the report there (docs/images/).
TEST(ReportCommand, PrintsThePdfThroughChromiumOnePagePerRecipe) {
  testing::ScratchDir dir("report-pdf");
  const std::string store = TwoRecipeStore(dir);
  const fs::path html = dir.path() / "report.html", pdf = dir.path() / "report.pdf";
  auto r = testing::RunFlatscan(fmt::format("report --store {} -o {} --pdf {}", store, html.string(), pdf.string()),
                                180);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, fmt::format("wrote {}: 8 records, 7 measured, yield 85.7%\nwrote {}: 3 pages\n", html.string(),
                               pdf.string()));
  EXPECT_EQ(PdfPageCount(testing::ReadFileBytes(pdf)), 3);
  EXPECT_EQ(PdfPageCount("<html>no pdf</html>"), 0);
  if (const char* shots = std::getenv("FLATSCAN_SCREENSHOTS")) {
    const std::string shot = (fs::path(shots) / "report.png").string();
    EXPECT_EQ(std::system(fmt::format("timeout 90 chromium --headless --no-sandbox --disable-gpu --hide-scrollbars "
                                      "--window-size=1000,1500 --user-data-dir={} --screenshot={} file://{} "
                                      ">/dev/null 2>&1",
                                      (dir.path() / "profile").string(), shot, html.string())
                              .c_str()),
              0);
  }

  // Chromium that cannot be started: exit 2, named, and neither file written.
  const fs::path html2 = dir.path() / "second.html", pdf2 = dir.path() / "second.pdf";
  r = testing::RunFlatscan(fmt::format("report --store {} -o {} --pdf {} --chromium /nonexistent/chromium", store,
                                       html2.string(), pdf2.string()));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(fmt::format("--pdf '{}': cannot start '/nonexistent/chromium': No such file or directory "
                                   "(install Debian's chromium)",
                                   pdf2.string())),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(html2));
  EXPECT_FALSE(fs::exists(pdf2));
  // A program that runs and fails: its exit code and what it printed.
  r = testing::RunFlatscan(fmt::format("report --store {} -o {} --pdf {} --chromium false", store, html2.string(),
                                       pdf2.string()));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("'false' printing the report failed (exit code 1)"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(html2));
}

}  // namespace
}  // namespace flatscan
