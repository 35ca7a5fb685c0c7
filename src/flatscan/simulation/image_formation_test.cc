#include "flatscan/simulation/image_formation.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace flatscan {
namespace {

TEST(ImageFormation, VaryingBlurEqualsTheUniformBlurWhenTheSigmaIsOneValue) {
  cv::Mat1f image(60, 80, 200.0f), uniform;
  cv::rectangle(image, cv::Rect(20, 15, 30, 25), cv::Scalar(20.0), cv::FILLED);
  uniform = image.clone();
  const std::vector<cv::Rect> regions = {cv::Rect(18, 13, 34, 29)};
  BlurRegions(uniform, 1.1, regions);
  BlurRegionsVarying(image, [](const cv::Rect& r) { return cv::Mat1f(r.size(), 1.1f); }, regions);
  EXPECT_LT(cv::norm(image, uniform, cv::NORM_INF), 1e-3);
}

TEST(ImageFormation, VaryingBlurGivesEachRowTheBlurOfItsOwnSigma) {
  // A vertical step edge; the sigma grows down the rows from 0.6 to 1.6 px.
  cv::Mat1f image(101, 60, 200.0f);
  image(cv::Rect(0, 0, 30, 101)).setTo(20.0f);
  const auto sigma_of_row = [](int y) { return 0.6 + y / 100.0; };
  const SigmaMap map = [&](const cv::Rect& r) {
    cv::Mat1f s(r.size());
    for (int y = 0; y < r.height; ++y) s.row(y).setTo(sigma_of_row(r.y + y));
    return s;
  };
  cv::Mat1f varying = image.clone();
  BlurRegionsVarying(varying, map, {cv::Rect(20, 0, 20, 101)});
  for (int y : {10, 37, 50, 90}) {
    cv::Mat1f row = image.row(y).clone(), blurred;
    const double sigma = sigma_of_row(y);
    cv::GaussianBlur(row, blurred, cv::Size(2 * static_cast<int>(std::ceil(4 * sigma)) + 1, 1), sigma, 0, cv::BORDER_REPLICATE);
    EXPECT_LT(cv::norm(varying.row(y), blurred, cv::NORM_INF), 0.2) << "row " << y;  // of a 180-grey step
  }
  // ... and the rows differ: the edge is wider below.
  EXPECT_LT(varying(90, 31), varying(10, 31) - 1.0f);
}

}  // namespace
}  // namespace flatscan
