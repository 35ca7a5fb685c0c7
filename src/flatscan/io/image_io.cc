#include "flatscan/io/image_io.h"

#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "flatscan/io/atomic_output.h"
#include "flatscan/util/error.h"

namespace flatscan {

cv::Mat1b ReadGreyImage(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) ThrowInputError("{}: no such file", path);
  if (std::filesystem::is_directory(path, ec)) ThrowInputError("{}: is a folder, not an image", path);
  cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (image.empty())
    ThrowInputError("{}: cannot read image (expected an 8-bit grey PNG, JPEG, BMP, TIFF or PGM file)", path);
  if (image.depth() != CV_8U && image.depth() != CV_16U)
    ThrowInputError("{}: {}-bit {} image not supported (expected 8-bit grey; 16-bit is converted)", path,
                    8 * image.elemSize1(), image.depth() == CV_32F || image.depth() == CV_64F ? "float" : "signed");
  switch (image.channels()) {
    case 1:
      break;
    case 2: {  // grey + alpha
      cv::Mat grey;
      cv::extractChannel(image, grey, 0);
      image = grey;
      spdlog::warn("{}: grey + alpha image: the alpha channel is ignored", path);
      break;
    }
    case 3:
    case 4: {
      cv::Mat grey;
      cv::cvtColor(image, grey, image.channels() == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
      image = grey;
      spdlog::warn("{}: colour image converted to grey (0.299 R + 0.587 G + 0.114 B)", path);
      break;
    }
    default:
      ThrowInputError("{}: image with {} channels not supported (expected 8-bit grey)", path, image.channels());
  }
  if (image.depth() == CV_16U) {
    double max_value = 0.0;
    cv::minMaxLoc(image, nullptr, &max_value);
    cv::Mat converted;
    if (max_value <= 255.0) {
      image.convertTo(converted, CV_8U);
      spdlog::warn("{}: 16-bit image with values up to {} converted to 8 bits unchanged", path, max_value);
    } else {
      image.convertTo(converted, CV_8U, 255.0 / max_value);
      spdlog::warn("{}: 16-bit image converted to 8 bits by scaling its maximum {} to 255 (grey x 255/{})", path,
                   max_value, max_value);
    }
    image = converted;
  }
  return image;
}

void WriteImage(const std::string& path, const cv::Mat& image) {
  WriteFileAtomically(path, [&](const std::filesystem::path& tmp) {
    if (!cv::imwrite(tmp.string(), image)) ThrowInputError("cannot write image '{}'", path);
  });
}

}  // namespace flatscan
