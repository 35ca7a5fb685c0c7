#include "flatscan/inspection/inspect_part.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "flatscan/simulation/dataset.h"

namespace flatscan {
namespace {

struct TrialError {
  double truth = 0, measured = 0, coverage = 0;
};

// Renders `count` random parts on the station and inspects them with the true rig
// and plane.
std::vector<TrialError> RunTrials(const SceneConfig& scene, int count, uint64_t seed, bool correction) {
  const Station st = BuildStation(scene);
  Random rng(seed);
  std::vector<TrialError> out;
  for (int i = 0; i < count; ++i) {
    const SimulatedPart part = SampleSimulatedPart(st, i, rng);
    const PartTruth& truth = part.shots[0].truth;
    const cv::Mat1b l = RenderPartImage(st, 0, part.geometry, truth.support_from_part, seed * 100 + 2 * i, false);
    const cv::Mat1b r = RenderPartImage(st, 1, part.geometry, truth.support_from_part, seed * 100 + 2 * i + 1, false);
    InspectionParams params;
    params.thickness_mm = part.geometry.SideHeight();
    params.thickness_correction = correction;
    const InspectionResult res = InspectPart(st.rig, st.plane, l, r, params);
    out.push_back({truth.flatness_mm, res.values.flatness_mm, res.coverage});
    if (getenv("VERBOSE"))
      printf("rot %.1f holes %zu notches %zu crossings %d/%d matched %d valid %d\n", part.shots[0].rotation_deg,
             part.geometry.holes.size(), part.geometry.notches.size(), res.crossings_left, res.crossings_right, res.matched, res.valid);
  }
  return out;
}

TEST(InspectPart, DISABLED_Explore) {
  const int n = getenv("N") ? atoi(getenv("N")) : 8;
  for (bool correction : {true, false}) {
    auto trials = RunTrials(ScenePreset("paper"), n, 11, correction);
    std::vector<double> errs;
    for (const auto& t : trials) {
      printf("truth %.4f measured %.4f err %+.4f coverage %.3f\n", t.truth, t.measured, t.measured - t.truth, t.coverage);
      errs.push_back(std::abs(t.measured - t.truth));
    }
    std::sort(errs.begin(), errs.end());
    printf("correction %d median %.4f p95 %.4f\n", correction, errs[errs.size() / 2], errs[errs.size() * 95 / 100]);
  }
}

}  // namespace
}  // namespace flatscan
