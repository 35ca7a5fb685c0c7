#pragma once
// Reading images as the pipeline needs them: 8-bit single-channel grey.
#include <optional>
#include <string>
#include <vector>

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

// As ReadGreyImage, with the SHA-256 of the very bytes it checked and decoded (one read of
// the whole file, after a peek at its header: a file replaced while it is read cannot
// lend its hash to another image).
struct HashedImage {
  cv::Mat1b image;
  std::string sha256;
};
HashedImage ReadGreyImageHashed(const std::string& path, const cv::Size& expected = {});

// Decodes an 8-bit grey, non-interlaced PNG (what cameras and the simulator write): the
// IDAT chunks inflated with libdeflate, then the row filters undone; an empty Mat for any
// other PNG (OpenCV's decoder takes those). Chunk CRCs are not checked here (ReadGreyImage
// checks them first, with messages that say where). Throws InputError naming `name` for
// data that do not decode to the image the header declares.
//
// Why our own: decoding is most of a station's work, and both Debian decoders spend it in
// zlib's inflate; libdeflate inflates about twice as fast. A 2592 x 1944 pair on one
// thread: OpenCV (libpng) 62.6 ms, libspng 67.7 ms, this 30.9 ms, against 22.9 ms of
// inspection (bench/inspect_bench, BM_DecodePngPair, same pair, same run).
cv::Mat1b DecodeGreyPng(const std::vector<unsigned char>& bytes, const std::string& name);

// Writes an image atomically (temporary name, then rename).
void WriteImage(const std::string& path, const cv::Mat& image);

}  // namespace flatscan
