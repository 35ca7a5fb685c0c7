#include "flatscan/boundary/boundary_report.h"

#include <gtest/gtest.h>

namespace flatscan {
namespace {

BoundaryResult TwoPoints() {
  BoundaryResult r;
  r.points = {{10.25, 20.5, 1.0, 0.0, 199.5, 0}, {10.25, 21.5, 0.6, 0.8, 200.0, 0}};
  r.contours = {{0, 2, false, 1.0}};
  return r;
}

TEST(BoundaryReport, CsvHasOneLinePerPointAfterTheHeader) {
  EXPECT_EQ(BoundaryPointsCsv(TwoPoints()),
            "x,y,nx,ny,h,contour\n10.2500,20.5000,1.00000,0.00000,199.50,0\n10.2500,21.5000,0.60000,0.80000,200.00,0\n");
}

TEST(BoundaryReport, OverlayIsTheUpscaledImageWithThePointsDrawn) {
  const cv::Mat1b image(40, 30, uchar(90));
  const cv::Mat3b overlay = DrawBoundaryOverlay(image, TwoPoints(), 4);
  EXPECT_EQ(overlay.cols, 120);
  EXPECT_EQ(overlay.rows, 160);
  // Pixel centre (10.25, 20.5) of the image is at 4 u + 1.5 in the overlay.
  EXPECT_NE(overlay(static_cast<int>(4 * 20.5 + 1.5), static_cast<int>(4 * 10.25 + 1.5)), cv::Vec3b(90, 90, 90));
  EXPECT_EQ(overlay(5, 5), cv::Vec3b(90, 90, 90));
}

}  // namespace
}  // namespace flatscan
