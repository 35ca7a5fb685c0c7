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

}  // namespace flatscan
