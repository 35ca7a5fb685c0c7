#pragma once
// `flatscan report`: what a supervisor reads about a period of a station's records, as one
// self-contained HTML file (charts drawn here as inline SVG: no script, no external file,
// nothing fetched; a factory PC has no internet).
//
// Per recipe in the records: the counts and the yield; the capability against the
// recipe's tolerance (spc/spc.h: Cpu, Ppu) and the individuals chart of the flatness
// values in time order with the Western Electric signals; a histogram against the
// tolerance; the worst parts; the calibration files the records were measured with (their
// hashes: a change of rig or plane is visible). Then the software versions and the exact
// query, so that the report can be made again.
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "flatscan/report/html_page.h"
#include "flatscan/report/shift_calendar.h"
#include "flatscan/spc/spc.h"
#include "flatscan/store/station_record.h"

namespace flatscan {

// Records counted by outcome (the report's tables and the station's web page).
struct RecordCounts {
  int64_t records = 0, measured = 0, pass = 0, fail = 0, marginal = 0, not_measured = 0;
  void Add(const InspectionRecord& record);
  // pass / measured (0 when nothing was measured); not-measured parts are not in it:
  // they are shown apart, as the station neither passed nor failed them.
  double Yield() const { return measured > 0 ? double(pass) / measured : 0.0; }
};

struct ReportedPart {
  int64_t sequence = 0;
  std::string time_utc, source_id;
  double flatness_mm = 0;
  std::string verdict;  // "pass", "fail" (with " (marginal)"), or "not measured: <reason>"
  std::string thumbnail;   // the archived thumbnail's path (record.archive.thumbnail), or ""
  std::string image_jpeg;  // its bytes, when the caller read them (AttachThumbnails)
};

struct RecipeReport {
  std::string name;
  double tolerance_mm = 0;           // of the last record (a change is listed in `tolerances`)
  std::vector<double> tolerances;    // every tolerance seen, in order of first use
  RecordCounts counts;
  std::vector<double> flatness_mm;   // measured parts, in sequence order
  std::optional<UpperCapability> capability;  // with 2 measured parts or more
  std::optional<IndividualsChart> chart;
  std::vector<RuleSignal> signals;
  std::vector<ReportedPart> worst;        // the highest flatness first (at most 10)
  std::vector<ReportedPart> not_measured; // the latest first (at most 10)
  std::vector<std::string> rigs, planes;  // SHA-256 of the files used, in order of first use
};

// One recipe over one day or one shift: the counts and, with 2 measured parts or more, the
// capability against the tolerance of the period's last record.
struct PeriodReport {
  std::string period;  // "2026-12-04" or "2026-12-04 06:00-14:00" (local time)
  std::string recipe;
  double tolerance_mm = 0;
  RecordCounts counts;
  std::optional<UpperCapability> capability;
};

struct StationReport {
  std::string query;          // the command that selects these records, as given
  std::string generated_utc;
  std::string first_utc, last_utc;  // of the records
  RecordCounts counts;
  std::vector<RecipeReport> recipes;  // by name
  std::vector<PeriodReport> days, shifts;  // in time order, then by recipe name
  std::vector<std::string> software_versions, stations;
};

// The report of `records` (in sequence order); `recipe_name` non-empty keeps that recipe's
// only; `shifts` sets the per-shift table's periods (days and shifts in local time).
StationReport SummariseRecords(const std::vector<StationRecord>& records, const std::string& recipe_name,
                               const std::string& query, const ShiftCalendar& shifts);

// Reads the thumbnails of the listed parts (worst and not measured) from their archived
// files; a file that is gone (the archive's quota) is left out. How many were read.
int AttachThumbnails(StationReport& report);

// The HTML page (UTF-8, one file; thumbnails embedded as data: URIs).
std::string RenderReportHtml(const StationReport& report);

}  // namespace flatscan
