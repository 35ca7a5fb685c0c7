#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "flatscan/exe/commands.h"
#include "flatscan/exe/store_access.h"
#include "flatscan/io/output_files.h"
#include "flatscan/io/pairs_csv.h"
#include "flatscan/store/postgres_results_store.h"
#include "flatscan/store/results_store.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

// The CSV's columns: the keys a spreadsheet filters and plots; the JSON has everything.
constexpr const char* kCsvHeader =
    "sequence,time_utc,source_id,recipe,measured,verdict,marginal,flatness_mm,lsq_pv_mm,minzone_mm,uncertainty_mm,"
    "coverage,error,station_id,record_id,recipe_sha256,left_sha256,right_sha256,software_version";

std::string Number(bool present, double value) { return present ? fmt::format("{}", value) : ""; }

std::string CsvLine(const StationRecord& r) {
  const InspectionRecord& in = r.inspection;
  const bool m = in.measured;
  return fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", r.sequence, r.time_utc,
                     CsvField(r.source_id), CsvField(r.recipe_name), m ? "true" : "false",
                     m ? VerdictName(in.judgement.verdict) : "", m && in.judgement.marginal ? "true" : "false",
                     Number(m, in.values.flatness_mm), Number(m, in.values.lsq_pv_mm), Number(m, in.values.minzone_mm),
                     Number(m, in.uncertainty.expanded_mm), Number(m, in.coverage), CsvField(m ? "" : in.error),
                     r.station_id, r.record_id, r.recipe_sha256, r.left_sha256, r.right_sha256,
                     CsvField(r.software_version));
}

class ResultsCommand : public Command {
 public:
  void Register(CLI::App& app) override {
    sub_ = app.add_subcommand("results", "Export a station's records from its results store: CSV for a spreadsheet, "
                                         "JSON lines (one record per line, every key) for tools.");
    sub_->footer("Example: flatscan results --store results.db --from 2026-12-04T06:00 --to 2026-12-04T14:00 --csv "
                 "shift.csv\nTimes are UTC (ISO 8601); --from is included, --to is not. Files default to standard "
                 "output; with neither --csv nor --json, JSON lines go to standard output.");
    sub_->add_option("--store", store_,
                     "results store: the SQLite file `flatscan station` writes, or the plant store "
                     "(postgresql://user@host:port/dbname: every station's records)")
        ->required();
    sub_->add_option("--from", from_, "first time (UTC, ISO 8601: 2026-12-04 or 2026-12-04T06:00:00Z), included");
    sub_->add_option("--to", to_, "last time (UTC, ISO 8601), excluded");
    csv_option_ = sub_->add_option("--csv", csv_, "CSV, to this file or standard output")->expected(0, 1);
    json_option_ =
        sub_->add_option("--json", json_, "JSON lines, to this file or standard output")->expected(0, 1)->excludes(csv_option_);
  }

  int Run() override {
    TimeRange range;
    if (!from_.empty()) range.from = ParseUtcTime(from_, "--from");
    if (!to_.empty()) range.to = ParseUtcTime(to_, "--to");
    const bool csv = csv_option_->count() > 0;
    std::string& target = csv ? csv_ : json_;
    if (target.empty()) target = "-";
    std::vector<OutputFiles::Named> inputs;
    if (!IsPostgresUri(store_)) inputs.push_back({"--store", store_});
    OutputFiles out(inputs);
    out.Declare(csv ? "--csv" : "--json", target, OutputFiles::kStdoutAllowed);
    const std::unique_ptr<ResultsStore> store = OpenStoreToRead(store_, "--store");
    const auto write = [&](std::ostream& os) {
      if (csv) os << kCsvHeader << "\n";
      store->ForEach(range, [&](const StationRecord& r) {
        if (csv) os << CsvLine(r);
        else os << StationRecordToJsonText(r) << "\n";
      });
    };
    if (target == "-") {
      write(std::cout);
      std::cout.flush();
      return 0;
    }
    out.Stage(csv ? "--csv" : "--json", [&](const std::filesystem::path& tmp) {
      std::ofstream os(tmp, std::ios::binary);
      write(os);
      if (!os.flush()) ThrowInputError("{}: cannot write", target);
    });
    out.Commit();
    return 0;
  }

 private:
  std::string store_, from_, to_, csv_, json_;
  CLI::Option* csv_option_ = nullptr;
  CLI::Option* json_option_ = nullptr;
};

}  // namespace

std::unique_ptr<Command> MakeResultsCommand() { return std::make_unique<ResultsCommand>(); }

}  // namespace flatscan
