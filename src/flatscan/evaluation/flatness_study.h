#pragma once
// The paper's two experiments (section 3) on a simulated station, inspected with
// calibrations made from simulated images:
//  - repeat study (Table 1): one part of known flatness shot many times, each shot
//    with fresh sensor noise and a small placement jitter (the part picked up and put
//    back): mean, variance and relative error of the measured flatness;
//  - batch study (Table 2): many different parts whose true flatness is spread like a
//    production lot around the tolerance, classified pass/fail against the truth.
// Positives are unqualified parts (true flatness_mm > tolerance), as in the paper:
//   Pr = TP / (TP + FP),  Rc = TP / (TP + FN),  Acc = (TP + TN) / all      (eq. 3.1)
// Parts are rendered in memory (never written) and measured in parallel; every
// random choice derives from the seed and the part's index, so results do not depend
// on the number of threads.
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "flatscan/evaluation/simulated_station.h"
#include "flatscan/flatness/verdict.h"
#include "flatscan/inspection/inspect_part.h"
#include "flatscan/simulation/dataset.h"
#include "flatscan/simulation/part_model.h"
#include "flatscan/util/random.h"

namespace flatscan {

struct PartMeasurement {
  std::string id;
  double true_flatness_mm = 0, true_lsq_pv_mm = 0, true_minzone_mm = 0;
  double thickness_mm = 0;   // side height given to the inspection (sheet + walls)
  double rotation_deg = 0;   // placement about the plane normal
  bool measured = false;
  std::string error;         // why it was not measured
  FlatnessValues values;     // measured
  double coverage = 0;
  PartUncertainty uncertainty;  // the part's own (inspection/part_uncertainty.h)
  int valid_points = 0;
  double inspect_ms = 0;     // InspectPart on the decoded pair (CPU time of its one thread)
  bool pass = false;         // the verdict on the measured flatness (Judge)
  double ErrorMm() const { return values.flatness_mm - true_flatness_mm; }
};

// Progress after each measured part: (done, total, that part).
using StudyProgress = std::function<void(int, int, const PartMeasurement&)>;

struct StudyOptions {
  double tolerance_mm = FlatnessSpec::kDefaultToleranceMm;  // verdicts: flatness/verdict.h
  uint64_t seed = 1;
  InspectionParams inspection;  // thickness_mm is set per part
};

// One pair to render and inspect: the studies' unit of work.
struct ShotJob {
  std::string id;
  PartGeometry geometry;
  PlacedShot shot;
  uint64_t noise_seed = 0;  // the pair's sensor noise and image defects derive from it
};

// Renders and inspects every job in parallel (results in the jobs' order); a part that
// cannot be measured keeps the reason in its `error`.
std::vector<PartMeasurement> MeasureShots(const CalibratedStation& station, const std::vector<ShotJob>& jobs,
                                          const StudyOptions& options, const StudyProgress& progress = {});

// The station with its dataset spec asking for `shots` placements per part.
Station WithShots(const Station& station, int shots);

// --- repeat study (Table 1) ---
struct RepeatStudyOptions : StudyOptions {
  int shots = 100;
  double flatness_mm = 0.323;  // the paper's part
};

struct ErrorSummary {
  int count = 0;
  double mean_mm = 0, sd_mm = 0;             // of the signed errors (measured - true)
  double median_abs_mm = 0, p95_abs_mm = 0, max_abs_mm = 0;
};
ErrorSummary SummarizeErrors(std::vector<double> errors_mm);

// A rotation's angle to the nearest of the baseline and its perpendicular, in [0, 45].
double AngleToBaselineDeg(double rotation_deg);

struct RepeatStudy {
  PartGeometry geometry;
  double true_flatness_mm = 0;
  std::vector<PartMeasurement> shots;
  // Over the measured shots: mean and sample variance of the measured flatness,
  // relative error |mean - true| / true, median inspection time.
  int measured = 0;
  double mean_mm = 0, variance_mm2 = 0, relative_error = 0, median_inspect_ms = 0;
  ErrorSummary errors;
};

// The repeat study's shots: one part of the options' flatness drawn from the seed,
// placed options.shots times (shot_000, shot_001, ...).
std::vector<ShotJob> RepeatJobs(const Station& station, const RepeatStudyOptions& options);

RepeatStudy RunRepeatStudy(const CalibratedStation& station, const RepeatStudyOptions& options,
                           const StudyProgress& progress = {});

// A shot or part of a study rendered again (the same images the study inspected), to
// look at it after the fact.
struct RenderedPart {
  SimulatedPart part;  // geometry and its one shot (pose and truth)
  cv::Mat1b left, right;
};
RenderedPart RenderRepeatShot(const CalibratedStation& station, const RepeatStudyOptions& options, int index);

// --- batch study (Table 2) ---
// Flatness of a production lot: log-normal, with the median set so that a fraction
// `beyond_fraction` lies above the tolerance, and `log_spread` the standard deviation
// of ln(flatness) (smaller: more parts near the tolerance); samples outside
// [min_mm, max_mm] are drawn again.
struct LotSpec {
  double beyond_fraction = 0.4;
  double log_spread = 0.8;
  double min_mm = 0.005, max_mm = 0.6;
};
// Throws InputError (fields lot.beyond_fraction, lot.log_spread, tolerance_mm) unless
// 0 < beyond_fraction < 1, log_spread > 0 and min_mm < tolerance_mm < max_mm.
void CheckLotSpec(const LotSpec& lot, double tolerance_mm);
double LotMedianMm(const LotSpec& lot, double tolerance_mm);
double SampleLotFlatness(const LotSpec& lot, double tolerance_mm, Random& rng);

struct BatchStudyOptions : StudyOptions {
  int parts = 1000;
  LotSpec lot;
};

struct Classification {
  int tp = 0, fp = 0, tn = 0, fn = 0;  // positive: unqualified (true flatness > tolerance)
  int unmeasured = 0;                  // no verdict: not counted above
  double precision = 0, recall = 0, accuracy = 0;
};
Classification Classify(const std::vector<PartMeasurement>& parts, double tolerance_mm);

// Guard band (ISO 14253-1 style): a measured value within `uncertainty_mm` of the
// tolerance is "marginal"; the others are decided pass or fail.
struct GuardBandSummary {
  double uncertainty_mm = 0;
  int marginal = 0;
  int decided = 0, decided_wrong = 0;  // among the non-marginal parts
  int wrong_marginal = 0;              // wrong plain verdicts that the band flags as marginal
  double decided_accuracy = 0;
};
GuardBandSummary ApplyGuardBand(const std::vector<PartMeasurement>& parts, double tolerance_mm, double uncertainty_mm);

struct BatchStudy {
  std::vector<PartMeasurement> parts;
  Classification classification;
  ErrorSummary errors;
  // The same split by the inspection's coverage: boundary stretches along the
  // epipolar rows cannot be measured and are completed from a warp fit.
  static constexpr double kGoodCoverage = 0.9;
  ErrorSummary errors_good_coverage, errors_low_coverage;
  // The same over the parts turned at least kTurnedDeg from the camera baseline (and
  // from its perpendicular: a rectangle's sides then cross the epipolar rows).
  static constexpr double kTurnedDeg = 5.0;
  ErrorSummary errors_turned;
  // Expanded uncertainty: the 95th percentile of |measured - true| over the lot.
  double uncertainty_mm = 0;
  GuardBandSummary guard_band;
  double true_beyond_fraction = 0;  // of the lot
  double near_tolerance_fraction = 0;  // true flatness within 10 um of the tolerance
  double median_inspect_ms = 0;
};

BatchStudy RunBatchStudy(const CalibratedStation& station, const BatchStudyOptions& options,
                         const StudyProgress& progress = {});

RenderedPart RenderBatchPart(const CalibratedStation& station, const BatchStudyOptions& options, int index);

// --- rotation study: what a part's rotation to the camera baseline costs ---
// The same `parts` parts (drawn like the batch's lot) placed at rotations 0, step,
// ..., max_deg about the support normal (0: the part's x axis along the baseline, so
// two sides run along the epipolar rows, which two cameras cannot measure).
struct RotationStudyOptions : StudyOptions {
  double max_deg = 45.0, step_deg = 5.0;
  int parts = 10;
  LotSpec lot;
};

struct RotationRow {
  double rotation_deg = 0;
  std::vector<PartMeasurement> parts;
  int measured = 0;
  double coverage_min = 0, coverage_median = 0;
  ErrorSummary errors;
};

struct RotationStudy {
  std::vector<RotationRow> rows;
};

RotationStudy RunRotationStudy(const CalibratedStation& station, const RotationStudyOptions& options,
                               const StudyProgress& progress = {});

// --- a simulated dataset on disk (the demo) ---
// Every part's first shot in a dataset folder (simulation/truth_file.h) inspected with
// the calibrated station, against its truth.
struct DatasetStudy {
  std::vector<PartMeasurement> parts;  // in truth.json's order
  ErrorSummary errors;
  int agree = 0;                       // measured parts whose verdict is the truth's
  double median_inspect_ms = 0;
};
DatasetStudy RunDatasetStudy(const CalibratedStation& station, const std::filesystem::path& dataset_dir,
                             const StudyOptions& options, const StudyProgress& progress = {});

// The `count` parts of a study with the largest |error| (those not measured first),
// rendered again by `render` (RenderBatchPart, RenderRepeatShot), written into `dir`
// as pairs to inspect again (simulation/truth_file.h, WritePartPairs).
void SaveWorstParts(const CalibratedStation& station, const std::vector<PartMeasurement>& parts, int count,
                    uint64_t seed, const std::filesystem::path& dir, const std::function<RenderedPart(int)>& render);

}  // namespace flatscan
