#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "flatscan/exe/commands.h"
#include "flatscan/io/output_files.h"
#include "flatscan/report/pdf_printer.h"
#include "flatscan/report/station_report.h"
#include "flatscan/store/results_store.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

class ReportCommand : public Command {
 public:
  void Register(CLI::App& app) override {
    sub_ = app.add_subcommand("report", "Write a self-contained HTML report of a station's records: counts and yield, "
                                        "capability (Cpu, Ppu), the control chart with the Western Electric rules, a "
                                        "histogram against the tolerance, the worst parts, the calibration files used.");
    sub_->footer("Example: flatscan report --store results.db --from 2026-12-04T06:00 --to 2026-12-04T14:00 "
                 "-o shift.html\nSee docs/spc.md.");
    sub_->add_option("--store", store_, "the station's results store (SQLite file)")->required();
    sub_->add_option("-o,--output", output_, "the HTML file to write")->required();
    sub_->add_option("--recipe-name", recipe_name_, "only the records of this recipe");
    sub_->add_option("--from", from_, "first time (UTC, ISO 8601), included");
    sub_->add_option("--to", to_, "last time (UTC, ISO 8601), excluded");
    sub_->add_option("--pdf", pdf_, "also print the report to this PDF file (headless Chromium)");
    sub_->add_option("--chromium", chromium_, "the Chromium program that prints the PDF")->default_val(chromium_);
    sub_->add_option("--shifts", shifts_, "local start times of the shifts, for the per-shift table")
        ->default_val(shifts_);
  }

  int Run() override {
    TimeRange range;
    if (!from_.empty()) range.from = ParseUtcTime(from_, "--from");
    if (!to_.empty()) range.to = ParseUtcTime(to_, "--to");
    const ShiftCalendar shifts = ShiftCalendar::Parse(shifts_, "--shifts");
    if (!std::filesystem::is_regular_file(store_)) ThrowInputError("--store '{}': no such results store", store_);
    OutputFiles out({{"--store", store_}});
    out.Declare("--output", output_);
    out.Declare("--pdf", pdf_);
    std::vector<StationRecord> records;
    try {
      OpenSqliteStore(store_, false)->ForEach(range, [&](const StationRecord& r) { records.push_back(r); });
    } catch (const StoreError& e) {
      ThrowInputError("--store: {}", e.what());
    }
    StationReport report;
    try {
      report = SummariseRecords(records, recipe_name_, Query(), shifts);
    } catch (const std::invalid_argument& e) {
      ThrowInputError("--store '{}': {}", store_, e.what());
    }
    if (report.counts.records == 0)
      ThrowInputError("--store '{}': no records{}{} (nothing to report)", store_,
                      recipe_name_.empty() ? "" : fmt::format(" of recipe '{}'", recipe_name_), RangeText());
    AttachThumbnails(report);
    const std::string html = RenderReportHtml(report);
    out.StageText("--output", html);
    int pages = 0;
    out.Stage("--pdf", [&](const std::filesystem::path& tmp) { pages = PrintPdf(html, tmp); });
    out.Commit();
    std::cout << fmt::format("wrote {}: {} records, {} measured, yield {:.1f}%\n", output_, report.counts.records,
                             report.counts.measured, 100 * report.counts.Yield());
    if (!pdf_.empty()) std::cout << fmt::format("wrote {}: {} pages\n", pdf_, pages);
    return 0;
  }

 private:
  // Chromium missing or failing is a run that could not be done (exit 2), like bad input.
  int PrintPdf(const std::string& html, const std::filesystem::path& pdf) const {
    try {
      return PrintHtmlToPdf(html, pdf, {chromium_, 120});
    } catch (const std::runtime_error& e) {
      ThrowInputError("--pdf '{}': {}", pdf_, e.what());
    }
  }

  std::string Query() const {
    std::string q = "flatscan report --store " + store_;
    if (!recipe_name_.empty()) q += " --recipe-name " + recipe_name_;
    if (!from_.empty()) q += " --from " + from_;
    if (!to_.empty()) q += " --to " + to_;
    q += " --shifts " + shifts_;
    return q;
  }
  std::string RangeText() const {
    if (from_.empty() && to_.empty()) return "";
    return fmt::format(" from {} to {}", from_.empty() ? "the start" : from_, to_.empty() ? "the end" : to_);
  }

  std::string store_, output_, recipe_name_, from_, to_, pdf_, chromium_ = "chromium", shifts_ = "06:00,14:00,22:00";
};

}  // namespace

std::unique_ptr<Command> MakeReportCommand() { return std::make_unique<ReportCommand>(); }

}  // namespace flatscan
