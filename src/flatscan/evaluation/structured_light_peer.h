#pragma once
// The structured-light peer of the paper's Table 1, measured on the same simulated
// parts as flatscan (simulation/structured_light.h renders its images).
//
// Patterns (OpenCV structured_light), P = 16 projector pixels a fringe period:
//  - a Gray code of the period index, 64 periods across the projector (GrayCodePattern of
//    64 x 2 "pixels" widened so that each code column is one period wide; 14 images with
//    their inverses), and a complementary one shifted by half a period (65 x 2, 16
//    images), whose stripe edges fall mid-period;
//  - white and black;
//  - three sinusoids shifted by 2 pi / 3 (SinusoidalPattern, PSP): 35 images in all.
//
// Decoding, per camera pixel lit by the projector (white - black > 20 grey):
//   k, k' = the two Gray codes' indices (GrayCodePattern::getProjPixel);
//   phi = the wrapped phase of the three fringes (SinusoidalPattern::computePhaseMap,
//         PSP, which band-passes each image around its fringe frequency first); OpenCV's
//         pattern is 127.5 + 127.5 sin(2 pi j / P + i 2 pi / 3) at projector column j and
//         its PSP phase is 2 pi j / P - pi / 2, so frac = (phi + pi / 2) / 2 pi mod 1;
//   column c = P (m + frac), m = k for frac in [1/4, 3/4), else k' (frac < 1/4) or k' - 1:
//         each code is read only a quarter period or more from its stripe edges, where a
//         blurred edge would decide a bit either way (the complementary Gray code method).
// OpenCV decodes the codes and the phase separately; combining them is ours.
// Triangulation: the camera pixel's ray (the rig's own camera model) meets the plane of
// projector column c (x / z = (c - cx) / fx in the projector frame). The rig's
// calibration is the true one (the peer's calibration error is not simulated: this
// favours it).
// Flatness: points more than half the part's side height above the support plane are
// the part's top; the mask is eroded by 12 px (OpenCV's PSP band-passes each image with a
// 21-bin window around the fringe frequency, which spreads the 0.2 mm height step at the
// part's edge over about 10 px: measured in structured_light_peer_test.cc) and the
// points averaged over 8 x 8 px cells lying wholly inside it (noise down by 8, as the
// peer's software smooths); each cell's height is its z minus the side height (the top
// stands a side height above the surface the part rests on). The three quantities then
// come from flatness_metrics.h over the whole top surface, which the peer sees and the
// boundary stereo does not (docs/evaluation.md: where each does better).
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "flatscan/evaluation/flatness_study.h"
#include "flatscan/flatness/flatness_metrics.h"
#include "flatscan/simulation/structured_light.h"

namespace flatscan {

struct StructuredLightPatterns {
  std::vector<cv::Mat1b> gray;          // with inverses, OpenCV's order
  std::vector<cv::Mat1b> gray_shifted;  // the same, half a period along
  cv::Mat1b white, black;
  std::vector<cv::Mat1b> fringes;   // three, PSP
};
StructuredLightPatterns MakeStructuredLightPatterns(const StructuredLightSpec& spec);

// The camera's images of every pattern for one placed part (same layout).
StructuredLightPatterns CapturePatterns(const StructuredLightRig& rig, const ProjectorView& view,
                                        const StructuredLightPatterns& patterns, uint64_t noise_seed);

// How the fringes' phase is computed: OpenCV's PSP (SinusoidalPattern::computePhaseMap,
// which band-passes each image around the fringe frequency with a rectangular window
// first: smooth, but it rings at the part's edge), or the textbook three-step formula
// per pixel, atan2(sqrt(3) (I3 - I2), 2 I1 - I2 - I3) (no filter: no ringing, more noise).
enum class PhaseMethod { kOpenCvPsp, kPerPixel };

// Decoded projector column per camera pixel (NaN where not decoded).
cv::Mat1f DecodeProjectorColumns(const StructuredLightSpec& spec, const StructuredLightPatterns& captured,
                                 PhaseMethod method = PhaseMethod::kOpenCvPsp);

// Camera pixel -> support-frame point (NaN where not decoded).
cv::Mat3f TriangulateColumns(const StructuredLightRig& rig, const cv::Mat1f& columns);

struct StructuredLightMeasurement {
  bool measured = false;
  std::string error;          // why not
  FlatnessValues values;
  int cells = 0;              // 8 x 8 px cells on the top surface
  std::vector<cv::Rect> cell_rects;  // their pixels
  double decode_ms = 0;       // decode + triangulation + flatness, one thread's CPU time
};
StructuredLightMeasurement MeasureStructuredLight(const StructuredLightRig& rig, const StructuredLightPatterns& captured,
                                                  double side_height_mm, PhaseMethod method = PhaseMethod::kOpenCvPsp);

// The simulator's true values over the same cells (each cell's mean true point): what
// the peer would report with a perfect decoding, to tell its measuring error apart from
// what it measures (the top surface inside the edge band, not the rim). A cell with a pixel
// whose ray meets no top (the part's side) is left out.
FlatnessValues TrueValuesOverCells(const ProjectorView& view, const std::vector<cv::Rect>& cells, double side_height_mm);

// The peer's rows of Table 1 over the same shots as flatscan's repeat study: one row per
// phase method, both decoded from the same captured images.
struct StructuredLightRow {
  PhaseMethod method = PhaseMethod::kOpenCvPsp;
  std::vector<StructuredLightMeasurement> shots;
  int measured = 0;
  double mean_mm = 0, variance_mm2 = 0, relative_error = 0, median_decode_ms = 0;
  ErrorSummary errors;       // flatness_mm - the shot's true flatness_mm (the rim's)
  ErrorSummary errors_seen;  // flatness_mm - the true flatness_mm over the cells it measured
};
struct StructuredLightStudy {
  StructuredLightSpec spec;
  int shots = 0;
  std::vector<StructuredLightRow> rows;  // OpenCV PSP, per pixel
};
StructuredLightStudy RunStructuredLightStudy(const Station& station, const std::vector<ShotJob>& jobs,
                                             const StructuredLightSpec& spec = {});

// "OpenCV PSP" / "per-pixel three-step".
const char* PhaseMethodName(PhaseMethod method);

}  // namespace flatscan
