#pragma once
// What `flatscan inspect` draws and writes beside the record (inspection_record.h):
// the PLY point cloud and overlay images.
#include <string>

#include <opencv2/core.hpp>

#include "flatscan/calibration/stereo_rig.h"
#include "flatscan/flatness/verdict.h"
#include "flatscan/inspection/inspect_part.h"

namespace flatscan {

// ASCII PLY: x y z (camera-1 frame, mm) and height (mm) of every valid point; atomic.
void WritePly(const std::string& path, const InspectionResult& result);

// The image of one camera with the matched points coloured by height (blue low, red
// high, on a scale from 0 to the larger of the tolerance and the flatness) and the
// verdict against `spec`.
cv::Mat3b DrawHeightOverlay(const cv::Mat1b& image, const InspectionResult& result, RigSide side,
                            const FlatnessSpec& spec);

// A small picture of one part for the station's page and reports: the left image cropped
// to the part (its rim points and a margin) and scaled to at most `max_width` pixels, the
// rim points coloured by height on a fixed scale from 0 to twice the tolerance (the same
// colours for every part of a recipe: blue 0, green at the tolerance, red at twice it and
// above), the highest point seen ringed and labelled ("highest seen": flatness_mm also
// counts the stretches completed from the warp model, so it can be higher), and a legend
// bar along the bottom.
// `result` nullptr (a part not measured): the whole image scaled, without points.
cv::Mat3b DrawRimThumbnail(const cv::Mat1b& left, const InspectionResult* result, const FlatnessSpec& spec,
                           int max_width = 480);

// The colour of a height on the thumbnail's scale (BGR): t = height / (2 tolerance),
// clamped to [0, 1], blue -> green -> red.
cv::Vec3b HeightColour(double height_mm, double tolerance_mm);

// JPEG bytes of an image (quality 0-100).
std::string EncodeJpeg(const cv::Mat& image, int quality = 80);

}  // namespace flatscan
