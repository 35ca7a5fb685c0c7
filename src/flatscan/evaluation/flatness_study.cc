#include "flatscan/evaluation/flatness_study.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <mutex>
#include <numeric>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include "flatscan/flatness/verdict.h"
#include "flatscan/io/image_io.h"
#include "flatscan/simulation/dataset.h"
#include "flatscan/simulation/truth_file.h"
#include "flatscan/util/error.h"
#include "flatscan/util/stage_timer.h"
#include "flatscan/util/statistics.h"

namespace flatscan {
namespace {

// The pair with the image defects the station's scene turns on (none by default),
// drawn from their own seed so that the parts and their noise do not change with them.
std::array<cv::Mat1b, 2> RenderShot(const CalibratedStation& station, const ShotJob& job) {
  const Rigid3d& pose = job.shot.truth.support_from_part;
  const ImageDefects defects =
      SampleImageDefects(station.truth.scene.image_effects, job.geometry, pose, Random::DeriveSeed(job.noise_seed, 2));
  return {RenderPartImage(station.truth, RigSide::kLeft, job.geometry, pose, Random::DeriveSeed(job.noise_seed, 0), false,
                          defects),
          RenderPartImage(station.truth, RigSide::kRight, job.geometry, pose, Random::DeriveSeed(job.noise_seed, 1), false,
                          defects)};
}

// Inspects one pair of the part `m` describes (its truth filled in) and records the
// measurement and its verdict; a part that cannot be measured keeps the reason.
PartMeasurement MeasurePair(const CalibratedStation& station, const cv::Mat1b& left, const cv::Mat1b& right,
                            const std::string& left_name, const std::string& right_name, PartMeasurement m,
                            const StudyOptions& options) {
  InspectionParams params = options.inspection;
  params.thickness_mm = m.thickness_mm;
  try {
    const double start = ThreadCpuMs();
    const InspectionResult result = InspectPart(station.rig(), station.plane(), left, right, params, left_name, right_name);
    m.inspect_ms = ThreadCpuMs() - start;
    m.measured = true;
    m.values = result.values;
    m.coverage = result.coverage;
    m.uncertainty = result.uncertainty;
    m.valid_points = result.valid;
    m.pass = Judge(result.values.flatness_mm, {options.tolerance_mm}).pass();
  } catch (const InputError& e) {
    m.error = e.what();
  }
  return m;
}

PartMeasurement MeasureShot(const CalibratedStation& station, const ShotJob& job, const StudyOptions& options) {
  PartMeasurement m;
  m.id = job.id;
  m.true_flatness_mm = job.shot.truth.flatness_mm;
  m.true_lsq_pv_mm = job.shot.truth.lsq_pv_mm;
  m.true_minzone_mm = job.shot.truth.minzone_mm;
  m.thickness_mm = job.geometry.SideHeight();
  m.rotation_deg = job.shot.rotation_deg;
  const auto [left, right] = RenderShot(station, job);
  return MeasurePair(station, left, right, job.id + " left", job.id + " right", std::move(m), options);
}

// measure(i) for i = 0 .. count - 1 in parallel; the results keep the index order.
std::vector<PartMeasurement> MeasureInParallel(size_t count, const std::function<PartMeasurement(size_t)>& measure,
                                               const StudyProgress& progress) {
  std::vector<PartMeasurement> out(count);
  std::mutex mutex;
  int done = 0;
  tbb::parallel_for(size_t{0}, count, [&](size_t i) {
    out[i] = measure(i);
    const std::lock_guard<std::mutex> lock(mutex);
    ++done;
    if (progress) progress(done, static_cast<int>(count), out[i]);
  });
  return out;
}

// Nearest-rank percentile of sorted values, q in (0, 1].
double Percentile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return 0;
  const size_t rank = static_cast<size_t>(std::ceil(q * sorted.size()));
  return sorted[std::clamp<size_t>(rank, 1, sorted.size()) - 1];
}

std::vector<double> MeasuredErrors(const std::vector<PartMeasurement>& parts) {
  std::vector<double> errors;
  for (const PartMeasurement& p : parts)
    if (p.measured) errors.push_back(p.ErrorMm());
  return errors;
}

double MedianInspectMs(const std::vector<PartMeasurement>& parts) {
  std::vector<double> ms;
  for (const PartMeasurement& p : parts)
    if (p.measured) ms.push_back(p.inspect_ms);
  return Median(ms);
}

// Inverse of the standard normal CDF by bisection on erfc (|error| < 1e-12).
double InverseNormalCdf(double p) {
  double lo = -10, hi = 10;
  for (int i = 0; i < 80; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

RenderedPart Rendered(const CalibratedStation& station, const ShotJob& job, int index) {
  const auto [left, right] = RenderShot(station, job);
  return {SimulatedPart{index, job.geometry, {job.shot}}, left, right};
}

}  // namespace

std::vector<ShotJob> RepeatJobs(const Station& station, const RepeatStudyOptions& options) {
  Random rng(options.seed);
  const PartGeometry geometry = WithFlatness(SamplePartGeometry(station.scene.part, rng), options.flatness_mm);
  const SimulatedPart part = PlaceSimulatedPart(WithShots(station, options.shots), 0, geometry, rng);
  std::vector<ShotJob> jobs;
  for (size_t s = 0; s < part.shots.size(); ++s)
    jobs.push_back({fmt::format("shot_{:03d}", s), part.geometry, part.shots[s], Random::DeriveSeed(options.seed ^ 0x7AB1E1ull, s)});
  return jobs;
}

std::vector<PartMeasurement> MeasureShots(const CalibratedStation& station, const std::vector<ShotJob>& jobs,
                                          const StudyOptions& options, const StudyProgress& progress) {
  return MeasureInParallel(
      jobs.size(), [&](size_t i) { return MeasureShot(station, jobs[i], options); }, progress);
}

Station WithShots(const Station& station, int shots) {
  Station out = station;
  out.scene.dataset.shots = shots;
  return out;
}

RenderedPart RenderRepeatShot(const CalibratedStation& station, const RepeatStudyOptions& options, int index) {
  return Rendered(station, RepeatJobs(station.truth, options).at(index), index);
}

ErrorSummary SummarizeErrors(std::vector<double> errors) {
  ErrorSummary s;
  s.count = static_cast<int>(errors.size());
  if (errors.empty()) return s;
  double sum = 0;
  for (double e : errors) sum += e;
  s.mean_mm = sum / errors.size();
  double ss = 0;
  for (double e : errors) ss += (e - s.mean_mm) * (e - s.mean_mm);
  s.sd_mm = errors.size() > 1 ? std::sqrt(ss / (errors.size() - 1)) : 0.0;
  for (double& e : errors) e = std::abs(e);
  std::sort(errors.begin(), errors.end());
  s.median_abs_mm = Median(errors);
  s.p95_abs_mm = Percentile(errors, 0.95);
  s.max_abs_mm = errors.back();
  return s;
}

RepeatStudy RunRepeatStudy(const CalibratedStation& station, const RepeatStudyOptions& options,
                           const StudyProgress& progress) {
  if (options.shots < 2) ThrowFieldError("repeat.shots", "expected at least 2 shots, got {}", options.shots);
  if (!(options.flatness_mm > 0))
    ThrowFieldError("repeat.flatness_mm", "expected a value > 0 mm, got {}", options.flatness_mm);
  const std::vector<ShotJob> jobs = RepeatJobs(station.truth, options);
  RepeatStudy study;
  study.geometry = jobs.front().geometry;
  study.true_flatness_mm = jobs.front().shot.truth.flatness_mm;
  study.shots = MeasureShots(station, jobs, options, progress);

  study.errors = SummarizeErrors(MeasuredErrors(study.shots));
  study.measured = study.errors.count;
  if (study.measured == 0) return study;
  study.mean_mm = study.true_flatness_mm + study.errors.mean_mm;
  study.variance_mm2 = study.errors.sd_mm * study.errors.sd_mm;
  study.relative_error = std::abs(study.mean_mm - study.true_flatness_mm) / study.true_flatness_mm;
  study.median_inspect_ms = MedianInspectMs(study.shots);
  return study;
}

double LotMedianMm(const LotSpec& lot, double tolerance_mm) {
  // P(f > tol) = 1 - Phi((ln tol - ln median) / s) = beyond
  return tolerance_mm * std::exp(-lot.log_spread * InverseNormalCdf(1.0 - lot.beyond_fraction));
}

void CheckLotSpec(const LotSpec& lot, double tolerance_mm) {
  if (!(lot.beyond_fraction > 0 && lot.beyond_fraction < 1))
    ThrowFieldError("lot.beyond_fraction", "expected a fraction between 0 and 1, got {}", lot.beyond_fraction);
  if (!(lot.log_spread > 0)) ThrowFieldError("lot.log_spread", "expected a value > 0, got {}", lot.log_spread);
  if (!(lot.min_mm < tolerance_mm && tolerance_mm < lot.max_mm))
    ThrowFieldError("tolerance_mm", "expected a value between {} and {} mm, got {}", lot.min_mm, lot.max_mm, tolerance_mm);
}

double SampleLotFlatness(const LotSpec& lot, double tolerance_mm, Random& rng) {
  CheckLotSpec(lot, tolerance_mm);
  const double log_median = std::log(LotMedianMm(lot, tolerance_mm));
  for (;;) {
    const double f = std::exp(rng.Normal(log_median, lot.log_spread));
    if (f >= lot.min_mm && f <= lot.max_mm) return f;
  }
}

Classification Classify(const std::vector<PartMeasurement>& parts, double tolerance_mm) {
  Classification c;
  for (const PartMeasurement& p : parts) {
    if (!p.measured) {
      ++c.unmeasured;
      continue;
    }
    const bool unqualified = !Judge(p.true_flatness_mm, {tolerance_mm}).pass(), detected = !p.pass;
    (unqualified ? (detected ? c.tp : c.fn) : (detected ? c.fp : c.tn))++;
  }
  const auto ratio = [](int a, int b) { return b > 0 ? static_cast<double>(a) / b : 0.0; };
  c.precision = ratio(c.tp, c.tp + c.fp);
  c.recall = ratio(c.tp, c.tp + c.fn);
  c.accuracy = ratio(c.tp + c.tn, c.tp + c.tn + c.fp + c.fn);
  return c;
}

GuardBandSummary ApplyGuardBand(const std::vector<PartMeasurement>& parts, double tolerance_mm, double uncertainty_mm) {
  GuardBandSummary g;
  g.uncertainty_mm = uncertainty_mm;
  for (const PartMeasurement& p : parts) {
    if (!p.measured) continue;
    const bool wrong = p.pass != Judge(p.true_flatness_mm, {tolerance_mm}).pass();
    if (Judge(p.values.flatness_mm, {tolerance_mm, uncertainty_mm}).marginal) {
      ++g.marginal;
      g.wrong_marginal += wrong;
    } else {
      ++g.decided;
      g.decided_wrong += wrong;
    }
  }
  g.decided_accuracy = g.decided > 0 ? 1.0 - static_cast<double>(g.decided_wrong) / g.decided : 0.0;
  return g;
}

namespace {

// A part drawn like the lot: its flatness from the lot, its shape, warp shape and
// placement from the station's scene.
SimulatedPart DrawLotPart(const Station& one_shot, const LotSpec& lot, double tolerance_mm, int id, Random& rng) {
  const double target = SampleLotFlatness(lot, tolerance_mm, rng);
  const PartGeometry geometry = WithFlatness(SamplePartGeometry(one_shot.scene.part, rng), target);
  return PlaceSimulatedPart(one_shot, id, geometry, rng);
}

ShotJob BatchJob(const Station& one_shot, const BatchStudyOptions& options, int index) {
  Random rng(Random::DeriveSeed(options.seed, index));
  const SimulatedPart part = DrawLotPart(one_shot, options.lot, options.tolerance_mm, index, rng);
  return {fmt::format("part_{:04d}", index), part.geometry, part.shots.front(), Random::DeriveSeed(options.seed ^ 0xBA7C4ull, index)};
}

}  // namespace

RenderedPart RenderBatchPart(const CalibratedStation& station, const BatchStudyOptions& options, int index) {
  return Rendered(station, BatchJob(WithShots(station.truth, 1), options, index), index);
}

double AngleToBaselineDeg(double rotation_deg) {
  const double r = std::fmod(std::fmod(rotation_deg, 90.0) + 90.0, 90.0);
  return std::min(r, 90.0 - r);
}

BatchStudy RunBatchStudy(const CalibratedStation& station, const BatchStudyOptions& options,
                         const StudyProgress& progress) {
  if (options.parts < 1) ThrowFieldError("batch.parts", "expected at least 1 part, got {}", options.parts);
  const Station one_shot = WithShots(station.truth, 1);
  std::vector<ShotJob> jobs(options.parts);
  tbb::parallel_for(0, options.parts, [&](int i) { jobs[i] = BatchJob(one_shot, options, i); });
  BatchStudy study;
  study.parts = MeasureShots(station, jobs, options, progress);
  study.classification = Classify(study.parts, options.tolerance_mm);
  study.errors = SummarizeErrors(MeasuredErrors(study.parts));
  std::vector<double> good, low;
  for (const PartMeasurement& p : study.parts)
    if (p.measured) (p.coverage >= BatchStudy::kGoodCoverage ? good : low).push_back(p.ErrorMm());
  study.errors_good_coverage = SummarizeErrors(good);
  study.errors_low_coverage = SummarizeErrors(low);
  std::vector<double> turned;
  for (const PartMeasurement& p : study.parts)
    if (p.measured && AngleToBaselineDeg(p.rotation_deg) >= BatchStudy::kTurnedDeg) turned.push_back(p.ErrorMm());
  study.errors_turned = SummarizeErrors(turned);
  study.uncertainty_mm = study.errors.p95_abs_mm;
  study.guard_band = ApplyGuardBand(study.parts, options.tolerance_mm, study.uncertainty_mm);
  int beyond = 0, near = 0;
  for (const PartMeasurement& p : study.parts) {
    beyond += !Judge(p.true_flatness_mm, {options.tolerance_mm}).pass();
    near += std::abs(p.true_flatness_mm - options.tolerance_mm) <= 0.010;
  }
  study.true_beyond_fraction = static_cast<double>(beyond) / options.parts;
  study.near_tolerance_fraction = static_cast<double>(near) / options.parts;
  study.median_inspect_ms = MedianInspectMs(study.parts);
  return study;
}

RotationStudy RunRotationStudy(const CalibratedStation& station, const RotationStudyOptions& options,
                               const StudyProgress& progress) {
  if (options.parts < 1) ThrowFieldError("rotation.parts", "expected at least 1 part, got {}", options.parts);
  if (!(options.step_deg > 0)) ThrowFieldError("rotation.step_deg", "expected a positive step, got {}", options.step_deg);
  if (!(options.max_deg >= 0))
    ThrowFieldError("rotation.max_deg", "expected a non-negative largest angle, got {}", options.max_deg);
  const int angles = static_cast<int>(std::floor(options.max_deg / options.step_deg + 1e-9)) + 1;
  std::vector<ShotJob> jobs(static_cast<size_t>(angles) * options.parts);
  tbb::parallel_for(0, static_cast<int>(jobs.size()), [&](int j) {
    const int angle = j / options.parts, k = j % options.parts;
    Station at_angle = WithShots(station.truth, 1);
    const double rotation = angle * options.step_deg;
    at_angle.scene.part.rotation_deg = {rotation, rotation};
    // The same draws for part k at every angle: only the rotation changes.
    Random rng(Random::DeriveSeed(options.seed ^ 0x507A7Eull, k));
    const SimulatedPart part = DrawLotPart(at_angle, options.lot, options.tolerance_mm, k, rng);
    jobs[j] = {fmt::format("rot{:04.1f}_part_{:02d}", rotation, k), part.geometry, part.shots.front(),
               Random::DeriveSeed(options.seed ^ 0x507A7Eull, j)};
  });
  const std::vector<PartMeasurement> measured = MeasureShots(station, jobs, options, progress);
  RotationStudy study;
  for (int angle = 0; angle < angles; ++angle) {
    RotationRow row;
    row.rotation_deg = angle * options.step_deg;
    row.parts.assign(measured.begin() + angle * options.parts, measured.begin() + (angle + 1) * options.parts);
    std::vector<double> coverage;
    for (const PartMeasurement& m : row.parts)
      if (m.measured) coverage.push_back(m.coverage);
    row.measured = static_cast<int>(coverage.size());
    if (!coverage.empty()) {
      row.coverage_min = *std::min_element(coverage.begin(), coverage.end());
      row.coverage_median = Median(coverage);
    }
    row.errors = SummarizeErrors(MeasuredErrors(row.parts));
    study.rows.push_back(std::move(row));
  }
  return study;
}

DatasetStudy RunDatasetStudy(const CalibratedStation& station, const std::filesystem::path& dataset_dir,
                             const StudyOptions& options, const StudyProgress& progress) {
  const std::vector<TruthPart> truth = ReadTruthFile(dataset_dir);
  DatasetStudy study;
  study.parts = MeasureInParallel(truth.size(), [&](size_t i) {
    const TruthPart& t = truth[i];
    PartMeasurement m;
    m.id = t.id;
    m.true_flatness_mm = t.flatness_mm;
    m.true_lsq_pv_mm = t.lsq_pv_mm;
    m.true_minzone_mm = t.minzone_mm;
    m.thickness_mm = t.side_height_mm;
    m.rotation_deg = t.shots.front().rotation_deg;
    try {
      const cv::Mat1b left = ReadGreyImage(t.shots.front().left), right = ReadGreyImage(t.shots.front().right);
      m = MeasurePair(station, left, right, t.shots.front().left, t.shots.front().right, std::move(m), options);
    } catch (const InputError& e) {
      m.error = e.what();
    }
    return m;
  }, progress);
  study.errors = SummarizeErrors(MeasuredErrors(study.parts));
  for (const PartMeasurement& p : study.parts)
    if (p.measured) study.agree += p.pass == Judge(p.true_flatness_mm, {options.tolerance_mm}).pass();
  study.median_inspect_ms = MedianInspectMs(study.parts);
  return study;
}

void SaveWorstParts(const CalibratedStation& station, const std::vector<PartMeasurement>& parts, int count,
                    uint64_t seed, const std::filesystem::path& dir, const std::function<RenderedPart(int)>& render) {
  std::vector<int> order(parts.size());
  std::iota(order.begin(), order.end(), 0);
  const auto badness = [&](int i) { return parts[i].measured ? std::abs(parts[i].ErrorMm()) : 1e9; };
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return badness(a) > badness(b); });
  order.resize(std::min<size_t>(order.size(), std::max(count, 0)));
  std::vector<PartPair> pairs;
  for (int i : order) {
    RenderedPart r = render(i);
    pairs.push_back({parts[i].id, std::move(r.part), std::move(r.left), std::move(r.right)});
  }
  WritePartPairs(dir, station.truth, seed, pairs);
}

}  // namespace flatscan
