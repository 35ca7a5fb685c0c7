// RenderReportHtml (station_report.h): one HTML file, the charts inline.
#include <fmt/format.h>

#include "flatscan/report/station_report.h"
#include "flatscan/report/svg_chart.h"

namespace flatscan {
namespace {

std::string Row(const std::vector<std::string>& cells, bool header = false) {
  std::string out = "<tr>";
  for (const std::string& c : cells) out += header ? "<th>" + c + "</th>" : "<td>" + c + "</td>";
  return out + "</tr>\n";
}

std::string Percent(const RecordCounts& c) { return c.measured ? fmt::format("{:.1f}%", 100 * c.Yield()) : "-"; }

std::string CountsTable(const RecordCounts& c) {
  return "<table>" + Row({"records", "measured", "pass", "fail", "marginal", "not measured", "yield"}, true) +
         Row({std::to_string(c.records), std::to_string(c.measured), std::to_string(c.pass),
              std::to_string(c.fail), std::to_string(c.marginal), std::to_string(c.not_measured),
              Percent(c)}) +
         "</table>\n";
}

// The per-day or per-shift table: one row per period and recipe.
std::string PeriodsTable(const std::vector<PeriodReport>& rows, const char* period) {
  std::string out = "<table>" + Row({period, "recipe", "records", "measured", "pass", "fail", "marginal",
                                     "not measured", "yield", "Cpu", "Ppu"},
                                    true);
  for (const PeriodReport& p : rows) {
    const RecordCounts& c = p.counts;
    out += Row({HtmlEscape(p.period), HtmlEscape(p.recipe), std::to_string(c.records), std::to_string(c.measured),
                std::to_string(c.pass), std::to_string(c.fail), std::to_string(c.marginal),
                std::to_string(c.not_measured), Percent(c),
                p.capability ? fmt::format("{:.2f}", p.capability->cpu) : "-",
                p.capability ? fmt::format("{:.2f}", p.capability->ppu) : "-"});
  }
  return out + "</table>\n";
}

std::string Thumbnail(const ReportedPart& p) {
  if (!p.image_jpeg.empty())
    return fmt::format("<img alt=\"part {}\" width=\"240\" src=\"{}\">", p.sequence,
                       DataUri("image/jpeg", p.image_jpeg));
  return p.thumbnail.empty() ? "-" : "<span class=\"note\">no longer in the archive</span>";
}

std::string PartsTable(const std::vector<ReportedPart>& parts, bool flatness) {
  std::string out =
      "<table>" + Row({"#", "time (UTC)", "part", flatness ? "flatness (mm)" : "reason", "thumbnail"}, true);
  for (const ReportedPart& p : parts)
    out += Row({std::to_string(p.sequence), HtmlEscape(p.time_utc), HtmlEscape(p.source_id),
                flatness ? fmt::format("{:.4f} {}", p.flatness_mm, HtmlEscape(p.verdict)) : HtmlEscape(p.verdict),
                Thumbnail(p)});
  return out + "</table>\n";
}

std::string Capability(const RecipeReport& r) {
  if (!r.capability) return "<p class=\"note\">Capability and the control chart need two measured parts or more.</p>\n";
  const UpperCapability& c = *r.capability;
  const IndividualsChart& i = *r.chart;
  std::string out = "<table>" + Row({"n", "mean (mm)", "sigma within (MRbar/1.128)", "sigma overall", "Cpu", "Ppu",
                                     "UCL (mm)", "MRbar (mm)", "MR UCL (mm)"},
                                    true);
  out += Row({std::to_string(c.n), fmt::format("{:.4f}", c.mean), fmt::format("{:.4f}", c.sigma_within),
              fmt::format("{:.4f}", c.sigma_overall), fmt::format("{:.2f}", c.cpu), fmt::format("{:.2f}", c.ppu),
              fmt::format("{:.4f}", i.ucl), fmt::format("{:.4f}", i.mr_bar), fmt::format("{:.4f}", i.mr_ucl)});
  out += "</table>\n<p class=\"note\">Cpu = (USL - mean) / (3 sigma within), Ppu = (USL - mean) / (3 sigma overall), "
         "USL the tolerance; flatness has no lower limit (docs/spc.md).</p>\n";
  out += ControlChartSvg(r.flatness_mm, i, r.tolerance_mm, r.signals) + MovingRangeChartSvg(i);
  if (r.signals.empty()) out += "<p>No Western Electric rule fires.</p>\n";
  else {
    out += fmt::format("<p class=\"fail\">{} Western Electric signal(s):</p><ul>\n", r.signals.size());
    for (const RuleSignal& s : r.signals)
      out += fmt::format("<li>part {} of the chart: rule {}, {} ({} the mean)</li>\n", s.index + 1, s.rule,
                         WesternElectricRuleText(s.rule), s.above ? "above" : "below");
    out += "</ul>\n";
  }
  return out + HistogramSvg(r.flatness_mm, r.tolerance_mm);
}

std::string Hashes(const std::vector<std::string>& hashes) {
  std::string out;
  for (const std::string& h : hashes) out += (out.empty() ? "" : ", ") + fmt::format("<code>{}</code>", HtmlEscape(h));
  return out.empty() ? "-" : out;
}

std::string Recipe(const RecipeReport& r) {
  std::string out = fmt::format("<section class=\"recipe\"><h2>Recipe {}</h2>\n<p>Tolerance {:.3f} mm", HtmlEscape(r.name), r.tolerance_mm);
  if (r.tolerances.size() > 1) out += fmt::format(" (changed during the period: {} tolerances)", r.tolerances.size());
  out += "</p>\n" + CountsTable(r.counts) + Capability(r);
  out += "<h3>Worst parts</h3>\n" + (r.worst.empty() ? std::string("<p>none measured</p>\n") : PartsTable(r.worst, true));
  if (!r.not_measured.empty()) out += "<h3>Not measured (latest)</h3>\n" + PartsTable(r.not_measured, false);
  out += fmt::format("<h3>Calibration</h3>\n<p>Rig files (SHA-256): {}<br>Plane files (SHA-256): {}</p>\n",
                     Hashes(r.rigs), Hashes(r.planes));
  if (r.rigs.size() > 1 || r.planes.size() > 1)
    out += "<p class=\"fail\">The calibration changed during the period.</p>\n";
  return out + "</section>\n";
}

}  // namespace

std::string RenderReportHtml(const StationReport& report) {
  std::string out = fmt::format(
      "<p>Records from {} to {} (UTC), stations {}.</p>\n", HtmlEscape(report.first_utc.empty() ? "-" : report.first_utc),
      HtmlEscape(report.last_utc.empty() ? "-" : report.last_utc), HtmlEscape(fmt::format("{}", fmt::join(report.stations, ", "))));
  out += "<h2>Summary</h2>\n" + CountsTable(report.counts);
  out += "<h2>By day</h2>\n" + PeriodsTable(report.days, "day (local)");
  out += "<h2>By shift</h2>\n" + PeriodsTable(report.shifts, "shift (local start day)");
  out += "<p class=\"note\">Cpu and Ppu per period need two measured parts or more in it; days and shifts in the "
         "station's local time (--shifts).</p>\n";
  for (const RecipeReport& r : report.recipes) out += Recipe(r);
  out += fmt::format("<h2>How this report was made</h2>\n<p>Query: <code>{}</code><br>Generated {} (UTC) by flatscan; "
                     "records measured by flatscan {}.</p>\n",
                     HtmlEscape(report.query), HtmlEscape(report.generated_utc),
                     HtmlEscape(fmt::format("{}", fmt::join(report.software_versions, ", "))));
  return HtmlPage("Flatness inspection report", out);
}

}  // namespace flatscan
