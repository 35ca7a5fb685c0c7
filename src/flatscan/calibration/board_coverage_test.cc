#include "flatscan/calibration/board_coverage.h"

#include <gtest/gtest.h>

namespace flatscan {
namespace {

// A board's corners filling the rectangle [x0, x1] x [y0, y1], 9 x 6 of them.
std::vector<cv::Point2f> BoardIn(float x0, float y0, float x1, float y1) {
  std::vector<cv::Point2f> corners;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 9; ++c) corners.emplace_back(x0 + (x1 - x0) * float(c) / 8, y0 + (y1 - y0) * float(r) / 5);
  return corners;
}

TEST(BoardCoverage, MarksTheCellsWhoseCentreTheBoardCovers) {
  BoardCoverage coverage(cv::Size(800, 600), 8, 6);  // cells of 100 x 100 px, centres at 50, 150, ...
  EXPECT_EQ(coverage.Covered(), 0);
  EXPECT_EQ(coverage.UncoveredRegions().size(), 9u);
  coverage.Add(BoardIn(20, 30, 260, 170));  // covers the centres x = 50, 150, 250 and y = 50, 150
  EXPECT_EQ(coverage.Covered(), 6);
  EXPECT_EQ(coverage.Rows(), (std::vector<std::string>{"###.....", "###.....", "........", "........", "........",
                                                         "........"}));
  EXPECT_EQ(coverage.UncoveredRegions(), (std::vector<std::string>{"top", "top right", "left", "centre", "right",
                                                                   "bottom left", "bottom", "bottom right"}));
  coverage.Add(BoardIn(20, 30, 260, 170));  // the same view again adds nothing
  EXPECT_EQ(coverage.Covered(), 6);
  coverage.Add(BoardIn(560, 420, 790, 590));  // bottom right: x = 650, 750; y = 450, 550
  EXPECT_EQ(coverage.Covered(), 10);
  EXPECT_EQ(coverage.Rows()[5], "......##");
  EXPECT_EQ(coverage.UncoveredRegions().back(), "bottom");
}

TEST(BoardCoverage, ATiltedBoardCoversItsOutlineOnly) {
  BoardCoverage coverage(cv::Size(800, 600), 8, 6);
  // A diamond around (400, 300) reaching 160 px out: the four cells whose centres are
  // 50 px from it in x and y are inside (|dx| + |dy| = 100), the next ones (150 + 50) outside.
  std::vector<cv::Point2f> diamond = {{400, 140}, {560, 300}, {400, 460}, {240, 300}};
  coverage.Add(diamond);
  EXPECT_EQ(coverage.Covered(), 4);
  EXPECT_TRUE(coverage.IsCovered(3, 2));
  EXPECT_TRUE(coverage.IsCovered(4, 3));
  EXPECT_FALSE(coverage.IsCovered(2, 2));
  EXPECT_EQ(coverage.UncoveredRegions().size(), 8u);  // the centre only
}

TEST(BoardCoverage, AnEmptyImageOrGridIsRefused) {
  EXPECT_THROW(BoardCoverage(cv::Size(0, 600)), std::invalid_argument);
  EXPECT_THROW(BoardCoverage(cv::Size(800, 600), 0, 6), std::invalid_argument);
}

}  // namespace
}  // namespace flatscan
