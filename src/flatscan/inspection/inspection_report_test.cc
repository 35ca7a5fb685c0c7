#include "flatscan/inspection/inspection_report.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

namespace flatscan {
namespace {

// The thumbnail's colour scale is fixed by the tolerance: blue at 0, green at the
// tolerance, red at twice it and beyond (the same colours for every part of a recipe).
TEST(RimThumbnail, HeightColoursAreOnAScaleOfTwiceTheTolerance) {
  EXPECT_EQ(HeightColour(0.0, 0.1), cv::Vec3b(255, 0, 0));
  EXPECT_EQ(HeightColour(0.1, 0.1), cv::Vec3b(0, 255, 0));
  EXPECT_EQ(HeightColour(0.2, 0.1), cv::Vec3b(0, 0, 255));
  EXPECT_EQ(HeightColour(0.5, 0.1), cv::Vec3b(0, 0, 255));  // clamped
  EXPECT_EQ(HeightColour(-0.01, 0.1), cv::Vec3b(255, 0, 0));
  EXPECT_EQ(HeightColour(0.05, 0.1), cv::Vec3b(127, 127, 0));
}

// A square rim of points in a 2000 x 1500 image, heights rising along it: the thumbnail is
// the part's box with a margin scaled to 480 wide, each point in its colour where it was
// seen, the highest ringed; a JPEG round trip keeps its size.
TEST(RimThumbnail, CropsToThePartColoursItsRimAndRingsTheHighestPoint) {
  const cv::Mat1b left(1500, 2000, uint8_t(40));
  InspectionResult r;
  for (int i = 0; i < 100; ++i) {
    InspectedPoint p;
    p.cam1.setZero();
    p.right_raw.setZero();
    p.outer = true;
    p.left_raw = {1000 + 4.0 * i, 700};  // the rim's top side, x from 1000 to 1396
    p.height_mm = 0.002 * i;             // up to 0.198 mm
    r.points.push_back(p);
    p.left_raw = {1000 + 4.0 * i, 1100};  // its bottom side, flat
    p.height_mm = 0;
    r.points.push_back(p);
  }
  const FlatnessSpec spec{0.1, 0};
  const cv::Mat3b thumb = DrawRimThumbnail(left, &r, spec, 480);
  // Box: x 1000-1396 and y 700-1100 with 0.2 * 400 = 80 px around: 556 x 560 px, scaled by
  // min(480 / 556, 360 / 560) = 0.643.
  const double scale = 360.0 / 560;
  EXPECT_EQ(thumb.rows, cvRound(560 * scale));
  EXPECT_EQ(thumb.cols, cvRound(556 * scale));
  const auto at = [&](double x, double y) { return thumb(cvRound((y - 620) * scale), cvRound((x - 920) * scale)); };
  EXPECT_EQ(at(1000, 1100), HeightColour(0, 0.1));         // a flat point: blue
  EXPECT_EQ(at(1000 + 4 * 50, 700), HeightColour(0.1, 0.1));  // at the tolerance: green
  // The ring around the highest point (1396, 700), 9 px above it: drawn there, not above
  // the lowest point of that side (1000, 700).
  const cv::Vec3b background(40, 40, 40);
  EXPECT_NE(thumb(cvRound((700 - 620) * scale) - 9, cvRound((1396 - 920) * scale)), background);
  EXPECT_EQ(thumb(cvRound((700 - 620) * scale) - 9, cvRound((1000 - 920) * scale)), background);
  const std::string jpeg = EncodeJpeg(thumb);
  const cv::Mat decoded = cv::imdecode(std::vector<uint8_t>(jpeg.begin(), jpeg.end()), cv::IMREAD_COLOR);
  EXPECT_EQ(decoded.size(), thumb.size());
  EXPECT_LT(jpeg.size(), 60000u);
  // A part not measured: the whole image, scaled, and no colour on it.
  const cv::Mat3b plain = DrawRimThumbnail(left, nullptr, spec, 480);
  EXPECT_EQ(plain.cols, 480);
  EXPECT_EQ(plain.rows, 360);
  EXPECT_EQ(plain(180, 240), cv::Vec3b(40, 40, 40));
}

}  // namespace
}  // namespace flatscan
