#include <filesystem>
#include <functional>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "flatscan/exe/commands.h"
#include "flatscan/exe/store_access.h"
#include "flatscan/gauge/gauge_data.h"
#include "flatscan/gauge/gauge_report.h"
#include "flatscan/io/output_files.h"
#include "flatscan/report/html_page.h"
#include "flatscan/report/svg_chart.h"
#include "flatscan/store/postgres_results_store.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

// flatscan gauge grr|type1|linearity: measurement system analyses of a gauge's data
// (docs/gauge.md). Exit 0 when the study ran (its acceptance is in the output), 2 when
// the data cannot make a study.
class GaugeCommand : public Command {
 public:
  void Register(CLI::App& app) override {
    sub_ = app.add_subcommand("gauge", "Measurement system analysis (MSA) of a gauge's measurements: gauge R&R by "
                                       "ANOVA, type 1 (Cg, Cgk), bias and linearity, agreement with a reference.");
    sub_->require_subcommand(1);
    sub_->footer("Each study: exit 0 when it ran (its acceptance is in the output), 2 when the data cannot make a "
                 "study.\nSee docs/gauge.md for the columns, the formulas and the acceptance limits.");
    grr_ = sub_->add_subcommand("grr", "Crossed gauge R&R by ANOVA (AIAG MSA 4th edition): EV, AV, interaction, GRR, "
                                       "PV, TV, %GRR of the tolerance and of TV, ndc.");
    grr_->footer("Example: flatscan gauge grr --data grr.csv --tolerance 0.1 --json grr.json\n"
                 "The data: columns part,appraiser,trial,value (mm); without appraiser: one station re-seating "
                 "the part for every trial.");
    AddCommon(grr_, "a CSV with the columns part,appraiser,trial,value (mm)");
    Fills(grr_->add_option("--alpha-interaction", grr_options_.alpha_interaction,
                           "the interaction is pooled into the repeatability when its p-value is above this")
              ->default_val(grr_options_.alpha_interaction),
          "alpha_interaction");

    type1_ = sub_->add_subcommand("type1", "Type 1 study (VDA 5): one reference part measured 25-50 times; bias, Cg, "
                                           "Cgk against the tolerance (limit 1.33).");
    type1_->footer("Example: flatscan gauge type1 --data type1.csv --tolerance 0.1 --reference 0.0812 --json t1.json");
    AddCommon(type1_, "a CSV with the column value (mm) and optionally trial and part");
    Fills(type1_->add_option("--reference", reference_mm_, "the reference part's calibrated value (mm)")->required(),
          "reference_mm");
    type1_->add_option("--part", part_, "with --store: the reference part's id (the records' study part); the "
                                        "store may hold other studies' parts");

    linearity_ = sub_->add_subcommand("linearity", "Bias and linearity over the range (AIAG MSA 4th edition): "
                                                   "reference parts measured several times each.");
    linearity_->footer("Example: flatscan gauge linearity --data lin.csv --json lin.json");
    linearity_->add_option("--data", data_, "a CSV with the columns part,reference,value (mm)")->required();
    linearity_->add_option("--json", json_, "write the study as JSON");
    linearity_->add_option("--html", html_, "write the study as an HTML page");

    agreement_ = sub_->add_subcommand("agreement", "Agreement with a reference instrument, part by part "
                                                   "(Bland-Altman: bias, limits of agreement; correlation).");
    agreement_->footer("Example: flatscan gauge agreement --data flatscan.csv --reference profiler.csv --tolerance 0.1\n"
                       "         flatscan gauge agreement --data flatscan.csv --reference-points profiler_points/ "
                       "--tolerance 0.1 --quantity minzone_mm");
    AddCommon(agreement_, "a CSV with the columns part,value[,trial] (mm): a part measured several times is "
                          "compared by its mean");
    auto* reference = agreement_->add_option("--reference", reference_,
                                             "the reference's values: a CSV with the columns part and flatness_mm, "
                                             "lsq_pv_mm and/or minzone_mm (mm)");
    auto* points = agreement_->add_option("--reference-points", reference_points_,
                                          "the reference's raw points: a folder of <part>.csv files with the columns "
                                          "x,y,z (mm, z above the surface plate); flatscan computes the quantity");
    reference->excludes(points);
    points->excludes(reference);
  }

  int Run() override {
    std::vector<OutputFiles::Named> inputs = {
        {"--data", data_}, {"--reference", reference_}, {"--reference-points", reference_points_}};
    if (!IsPostgresUri(store_)) inputs.push_back({"--store", store_});
    OutputFiles out(inputs);
    out.Declare("--json", json_);
    out.Declare("--html", html_);
    nlohmann::json json;
    std::string markdown, html_extra;
    if (grr_->parsed()) {
      grr_options_.tolerance_mm = tolerance_mm_;
      const std::vector<GaugeObservation> data = Observations(ReadGaugeRRCsv);
      const GaugeRRResult result = AnalyseGaugeRR(data, grr_options_, Source());
      json = GaugeRRJson(result, grr_options_);
      markdown = GaugeRRMarkdown(result, grr_options_, Source());
    } else if (type1_->parsed()) {
      const Type1Options options{tolerance_mm_, reference_mm_};
      const std::vector<double> values = Type1Values();
      const Type1Result result = AnalyseType1(values, options, Source());
      json = Type1Json(result, options);
      markdown = Type1Markdown(result, options, Source());
    } else if (agreement_->parsed()) {
      markdown = RunAgreement(json, html_extra);
    } else {
      const LinearityResult result = AnalyseLinearity(ReadLinearityCsv(data_), data_);
      json = LinearityJson(result);
      markdown = LinearityMarkdown(result, data_);
    }
    json[store_.empty() ? "data" : "store"] = Source();
    out.StageText("--json", json.dump(2) + "\n");
    out.StageText("--html", HtmlPage("flatscan gauge study", MarkdownToHtml(markdown) + html_extra));
    out.Commit();
    std::cout << markdown;
    return 0;
  }

 private:
  std::string Source() const { return store_.empty() ? data_ : store_; }

  // The study's measurements: --data read by `read`, or the tagged records of --store;
  // refused when they look like micrometres.
  std::vector<GaugeObservation> Observations(
      const std::function<std::vector<GaugeObservation>(const std::filesystem::path&)>& read) const {
    if (data_.empty() && store_.empty()) ThrowInputError("gauge: expected --data FILE or --store STORE");
    const std::vector<GaugeObservation> data = store_.empty() ? read(data_) : TaggedRecords();
    std::vector<double> values;
    for (const GaugeObservation& o : data) values.push_back(o.value);
    CheckMillimetres(values, tolerance_mm_, Source());
    return data;
  }

  // A type 1 study's values: its CSV (one part by construction) or the tagged records of one part.
  std::vector<double> Type1Values() const {
    if (!part_.empty() && store_.empty())
      ThrowInputError("--part '{}': it chooses the records of --store; a --data file holds one part", part_);
    const std::vector<GaugeObservation> data = Observations([](const std::filesystem::path& file) {
      std::vector<GaugeObservation> observations;
      for (double value : ReadType1Csv(file)) observations.push_back({"", "", "", value, 0});
      return observations;
    });
    std::vector<double> values;
    for (const GaugeObservation& o : data) {
      if (!part_.empty() && o.part != part_) continue;
      if (o.part != data.front().part && part_.empty())
        ThrowInputError("--store '{}': records of part '{}' and of part '{}': a type 1 study measures one reference "
                        "part (choose it with --part)",
                        store_, data.front().part, o.part);
      values.push_back(o.value);
    }
    if (!part_.empty() && values.empty())
      ThrowInputError("--part '{}': {} has no value of that part", part_, Source());
    return values;
  }

  // The records of --store with study tags, as observations of --quantity. A tagged record
  // that was not measured is refused: the study would silently lose a trial.
  std::vector<GaugeObservation> TaggedRecords() const {
    const FlatnessQuantity q = ParseFlatnessQuantity(quantity_, "--quantity");
    std::vector<GaugeObservation> out;
    OpenStoreToRead(store_, "--store")->ForEach(TimeRange{}, [&](const StationRecord& r) {
      if (r.study.Empty() || (!recipe_name_.empty() && r.recipe_name != recipe_name_)) return;
      const std::string appraiser = r.study.appraiser.empty() ? r.station_id : r.study.appraiser;
      if (!r.inspection.measured)
        ThrowInputError("--store '{}': record {} (part '{}', appraiser '{}', trial '{}') was not measured: {} (measure "
                        "the part again, or leave its trials out of the study)",
                        store_, r.sequence, r.study.part, appraiser, r.study.trial, r.inspection.error);
      out.push_back({r.study.part, appraiser, r.study.trial, ValueOf(r.inspection.values, q), 0});
    });
    if (out.empty())
      ThrowInputError("--store '{}': no records with study tags (part, appraiser, trial){} (give them in the pairs "
                      "file's columns part, appraiser, trial)",
                      store_, recipe_name_.empty() ? "" : fmt::format(" of recipe '{}'", recipe_name_));
    return out;
  }

  // The agreement study; its Bland-Altman plot goes into `html_extra`.
  std::string RunAgreement(nlohmann::json& json, std::string& html_extra) {
    const FlatnessQuantity q = ParseFlatnessQuantity(quantity_, "--quantity");
    if (reference_.empty() && reference_points_.empty())
      ThrowInputError("gauge agreement: expected --reference FILE or --reference-points FOLDER");
    const std::string reference_name = reference_.empty() ? reference_points_ : reference_;
    const ReferenceTable reference =
        reference_.empty() ? ReadReferencePoints(reference_points_) : ReadReferenceCsv(reference_);
    const std::vector<GaugeObservation> data = Observations(ReadAgreementCsv);
    const AgreementResult result =
        AnalyseAgreement(PairWithReference(data, reference, q, Source(), reference_name), Source());
    json = AgreementJson(result, quantity_, tolerance_mm_);
    json["reference"] = reference_name;
    std::vector<double> means, differences;
    for (const AgreementPair& p : result.pairs) {
      means.push_back(0.5 * (p.measured + p.reference));
      differences.push_back(1000 * (p.measured - p.reference));
    }
    html_extra = "<p>" + BlandAltmanSvg(means, differences, 1000 * result.bias, 1000 * result.lower_loa,
                                       1000 * result.upper_loa) + "</p>\n";
    return AgreementMarkdown(result, quantity_, tolerance_mm_, fmt::format("{} against {}", Source(), reference_name));
  }

  // --data FILE or --store STORE (the station's records that carry study tags), and the rest.
  void AddCommon(CLI::App* study, const std::string& data_help) {
    auto* data = study->add_option("--data", data_, data_help);
    auto* store = study->add_option("--store", store_,
                                    "instead of --data: the records with study tags (part, appraiser, trial) in a "
                                    "results store (SQLite file or postgresql://...); the appraiser defaults to the "
                                    "record's station");
    data->excludes(store);
    store->excludes(data);
    study->add_option("--recipe-name", recipe_name_, "with --store: only the records of this recipe");
    study->add_option("--quantity", quantity_, "the value studied: flatness_mm, lsq_pv_mm or minzone_mm (with "
                                               "--store; agreement: also what the reference gives)")
        ->default_val(quantity_);
    Fills(study->add_option("--tolerance", tolerance_mm_, "the tolerance T (mm): flatness's upper limit")->required(),
          "tolerance_mm");
    study->add_option("--json", json_, "write the study as JSON");
    study->add_option("--html", html_, "write the study as an HTML page");
  }

  CLI::App *grr_ = nullptr, *type1_ = nullptr, *linearity_ = nullptr, *agreement_ = nullptr;
  std::string data_, store_, recipe_name_, json_, html_, reference_, reference_points_, part_, quantity_ = "flatness_mm";
  double tolerance_mm_ = 0, reference_mm_ = 0;
  GaugeRROptions grr_options_;
};

}  // namespace

std::unique_ptr<Command> MakeGaugeCommand() { return std::make_unique<GaugeCommand>(); }

}  // namespace flatscan
