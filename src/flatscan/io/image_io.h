#pragma once
// Reading images as the pipeline needs them: 8-bit single-channel grey.
#include <optional>
#include <string>

#include <opencv2/core.hpp>

namespace flatscan {

// The largest image flatscan decodes, in pixels (100 megapixels: 100 MB as 8-bit grey,
// within the process's 1 GB; today's machine-vision sensors reach about 65 MP).
constexpr long long kMaxImagePixels = 100'000'000;

// The image size a PNG, JPEG, BMP, TIFF or PGM/PPM file's header declares, read without
// decoding the image; nullopt for other formats or a header that cannot be read. Only
// these formats are read (ReadGreyImage refuses the others).
std::optional<cv::Size> ReadImageHeaderSize(const std::string& path);

// Reads `path` as 8-bit grey. Colour (BGR/BGRA) and grey+alpha images are converted
// with a warning; 16-bit images are converted to 8 bits (scaled by their maximum
// when it exceeds 255) with a warning. Before decoding, the size in the file's header
// is checked against kMaxImagePixels and, when `expected` is not empty (the rig's image
// size), against it. Throws InputError naming the file for a missing, unreadable,
// oversized, wrongly sized or unsupported image.
cv::Mat1b ReadGreyImage(const std::string& path, const cv::Size& expected = {});

// Writes an image atomically (temporary name, then rename).
void WriteImage(const std::string& path, const cv::Mat& image);

}  // namespace flatscan
