#pragma once
// Reading images as the pipeline needs them: 8-bit single-channel grey.
#include <string>

#include <opencv2/core.hpp>

namespace flatscan {

// Reads `path` as 8-bit grey. Colour (BGR/BGRA) and grey+alpha images are converted
// with a warning; 16-bit images are converted to 8 bits (scaled by their maximum
// when it exceeds 255) with a warning. Throws InputError naming the file for a
// missing, unreadable or unsupported image.
cv::Mat1b ReadGreyImage(const std::string& path);

// Writes an image atomically (temporary name, then rename).
void WriteImage(const std::string& path, const cv::Mat& image);

}  // namespace flatscan
