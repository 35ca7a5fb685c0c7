#include "flatscan/evaluation/gauge_twin.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "flatscan/gauge/gauge_report.h"
#include "flatscan/util/error.h"
#include "flatscan/util/statistics.h"

namespace flatscan {
namespace {

// Seeds of the study's random streams, apart from the other studies' (flatness_study.cc).
constexpr uint64_t kPartStream = 0x6A06E0ull, kPlacementStream = 0x71A1A1ull, kNoiseStream = 0x40153Eull;

// A part of the study: its geometry, drawn from its own stream.
PartGeometry StudyPart(const Station& station, double flatness_mm, uint64_t seed, int index) {
  Random rng(Random::DeriveSeed(seed ^ kPartStream, index));
  return WithFlatness(SamplePartGeometry(station.scene.part, rng), flatness_mm);
}

// Trial `trial` of a part: a new placement anywhere in the common field of view, its own noise.
ShotJob TrialJob(const Station& one_shot, const PartGeometry& geometry, const std::string& id, uint64_t seed,
                 uint64_t trial) {
  Random rng(Random::DeriveSeed(seed ^ kPlacementStream, trial));
  const SimulatedPart placed = PlaceSimulatedPart(one_shot, 0, geometry, rng);
  return {id, placed.geometry, placed.shots.front(), Random::DeriveSeed(seed ^ kNoiseStream, trial)};
}

struct PlannedPart {
  std::string label;
  PartGeometry geometry;
  int trials = 0;
};

// Every trial of `parts` on `station`; trial numbers `first_trial`.. keep each stream apart.
std::vector<PartMeasurement> MeasureTrials(const CalibratedStation& station, const std::vector<PlannedPart>& parts,
                                           const StudyOptions& options, uint64_t first_trial,
                                           const StudyProgress& progress) {
  const Station one_shot = WithShots(station.truth, 1);
  std::vector<ShotJob> jobs;
  uint64_t trial = first_trial;
  for (const PlannedPart& p : parts)
    for (int k = 0; k < p.trials; ++k)
      jobs.push_back(TrialJob(one_shot, p.geometry, fmt::format("{} trial {}", p.label, k + 1), options.seed, trial++));
  return MeasureShots(station, jobs, options, progress);
}

void CountInto(TwinGaugeStudy& study, const std::vector<PartMeasurement>& measured, std::vector<double>& inspect_ms) {
  for (const PartMeasurement& m : measured) {
    study.not_measured += !m.measured;
    if (m.measured) inspect_ms.push_back(m.inspect_ms);
  }
}

void RunGrr(const std::vector<const CalibratedStation*>& stations, const TwinGaugeOptions& options,
            const StudyProgress& progress, TwinGaugeStudy& study, std::vector<double>& inspect_ms) {
  const Station& scene_station = stations.front()->truth;
  std::vector<PlannedPart> parts;
  for (int i = 0; i < options.parts; ++i) {
    Random rng(Random::DeriveSeed(options.seed ^ kPartStream, 1000 + i));
    const double flatness = SampleLotFlatness(options.lot, options.tolerance_mm, rng);
    parts.push_back({fmt::format("part_{:02d}", i + 1), StudyPart(scene_station, flatness, options.seed, i),
                     options.trials});
  }
  std::vector<std::vector<PartMeasurement>> by_station;
  for (size_t s = 0; s < stations.size(); ++s) {
    // Each station places the parts its own way (trial streams apart per station).
    by_station.push_back(MeasureTrials(*stations[s], parts, options, (s + 1) * 1000000, progress));
    CountInto(study, by_station.back(), inspect_ms);
  }
  for (int i = 0; i < options.parts; ++i) {
    bool all = true;
    for (const auto& measured : by_station)
      for (int k = 0; k < options.trials; ++k) all = all && measured[i * options.trials + k].measured;
    if (!all) {
      ++study.grr_parts_dropped;
      continue;
    }
    for (size_t s = 0; s < stations.size(); ++s)
      for (int k = 0; k < options.trials; ++k)
        study.grr_data.push_back({parts[i].label, study.appraisers[s], std::to_string(k + 1),
                                  by_station[s][i * options.trials + k].values.flatness_mm, 0});
  }
  study.grr = AnalyseGaugeRR(study.grr_data, {options.tolerance_mm, GaugeRROptions{}.alpha_interaction},
                             "the twin's gauge R&R");
}

}  // namespace

TwinGaugeStudy RunTwinGaugeStudy(const std::vector<const CalibratedStation*>& stations,
                                 const std::vector<std::string>& names, const TwinGaugeOptions& options,
                                 const StudyProgress& progress) {
  FLATSCAN_CHECK(!stations.empty() && stations.size() == names.size());
  if (options.parts < 1 || options.trials < 1)
    ThrowFieldError("gauge.parts", "expected at least 1 part and 1 trial, got {} x {}", options.parts, options.trials);
  TwinGaugeStudy study;
  study.appraisers = names;
  std::vector<double> inspect_ms;
  RunGrr(stations, options, progress, study, inspect_ms);

  const CalibratedStation& first = *stations.front();
  const PartGeometry reference_part = StudyPart(first.truth, options.type1_flatness_mm, options.seed, 2000);
  const std::vector<PartMeasurement> type1 =
      MeasureTrials(first, {{"reference", reference_part, options.type1_trials}}, options, 2000000, progress);
  CountInto(study, type1, inspect_ms);
  study.type1_reference_mm = type1.front().true_flatness_mm;
  for (const PartMeasurement& m : type1)
    if (m.measured) study.type1_values.push_back(m.values.flatness_mm);
  study.type1 = AnalyseType1(study.type1_values, {options.tolerance_mm, study.type1_reference_mm}, "the twin's type 1");

  std::vector<PlannedPart> linearity_parts;
  for (int i = 0; i < options.linearity_parts; ++i) {
    const double f = options.tolerance_mm * (0.2 + 1.6 * i / std::max(1, options.linearity_parts - 1));
    linearity_parts.push_back(
        {fmt::format("ref_{}", i + 1), StudyPart(first.truth, f, options.seed, 3000 + i), options.linearity_trials});
  }
  const std::vector<PartMeasurement> linearity = MeasureTrials(first, linearity_parts, options, 3000000, progress);
  CountInto(study, linearity, inspect_ms);
  for (size_t k = 0; k < linearity.size(); ++k) {
    // The part's reference: its truth (the same in every placement; taken from its first trial).
    const size_t part = k / options.linearity_trials;
    if (linearity[k].measured)
      study.linearity_data.push_back({linearity_parts[part].label,
                                      linearity[part * options.linearity_trials].true_flatness_mm,
                                      linearity[k].values.flatness_mm, 0});
  }
  study.linearity = AnalyseLinearity(study.linearity_data, "the twin's linearity study");
  study.median_inspect_ms = Median(inspect_ms);
  return study;
}

std::string TwinGaugeMarkdown(const TwinGaugeStudy& study, const TwinGaugeOptions& options) {
  std::string md = fmt::format(
      "## Gauge studies on the twin\n\nEvery trial is a new placement (anywhere in the field of view, any "
      "rotation) with fresh noise; the reference is the twin's truth. Stations (appraisers): {}. Trials not measured: "
      "{}; parts left out of the gauge R&R (not measured in some trial): {}. Median inspection {:.1f} ms.\n\n",
      fmt::join(study.appraisers, ", "), study.not_measured, study.grr_parts_dropped, study.median_inspect_ms);
  md += GaugeRRMarkdown(study.grr, {options.tolerance_mm, GaugeRROptions{}.alpha_interaction}, "gauge R&R") + "\n";
  md += Type1Markdown(study.type1, {options.tolerance_mm, study.type1_reference_mm}, "type 1") + "\n";
  md += LinearityMarkdown(study.linearity, "linearity");
  return md;
}

nlohmann::json TwinGaugeJson(const TwinGaugeStudy& study, const TwinGaugeOptions& options) {
  return {{"appraisers", study.appraisers},
          {"not_measured", study.not_measured},
          {"grr_parts_dropped", study.grr_parts_dropped},
          {"median_inspect_ms", study.median_inspect_ms},
          {"grr", GaugeRRJson(study.grr, {options.tolerance_mm, GaugeRROptions{}.alpha_interaction})},
          {"type1", Type1Json(study.type1, {options.tolerance_mm, study.type1_reference_mm})},
          {"linearity", LinearityJson(study.linearity)}};
}

}  // namespace flatscan
