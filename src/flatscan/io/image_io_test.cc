#include "flatscan/io/image_io.h"

#include <fstream>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

TEST(ImageHeader, SizeOfEveryFormatTheStationReads) {
  testing::ScratchDir dir("image-header");
  const cv::Mat1b image(37, 53, uchar{128});
  for (const char* ext : {".png", ".jpg", ".bmp", ".pgm", ".tif"}) {
    const std::string path = (dir.path() / (std::string("grey") + ext)).string();
    ASSERT_TRUE(cv::imwrite(path, image)) << ext;
    const std::optional<cv::Size> size = ReadImageHeaderSize(path);
    ASSERT_TRUE(size.has_value()) << ext;
    EXPECT_EQ(*size, cv::Size(53, 37)) << ext;
  }
  std::ofstream(dir.path() / "text.png") << "not an image";
  EXPECT_FALSE(ReadImageHeaderSize((dir.path() / "text.png").string()).has_value());
}

// Before: a PNG whose header claims 100000 x 100000 px gave a raw OpenCV assertion
// without the file name, and a 20000 x 20000 image was decoded (843 MB) before it was
// refused.
TEST(ImageHeader, OversizedOrWronglySizedImagesAreRefusedBeforeDecoding) {
  testing::ScratchDir dir("image-oversized");
  const std::string small = (dir.path() / "small.png").string();
  ASSERT_TRUE(cv::imwrite(small, cv::Mat1b(8, 8, uchar{200})));
  std::string bytes = testing::ReadFileBytes(small);
  const std::string claimed = (dir.path() / "claims_huge.png").string();
  for (int i : {16, 20}) {  // IHDR width and height, big-endian: 100000 = 0x000186A0
    bytes[i] = 0;
    bytes[i + 1] = 0x01;
    bytes[i + 2] = static_cast<char>(0x86);
    bytes[i + 3] = static_cast<char>(0xA0);
  }
  std::ofstream(claimed, std::ios::binary) << bytes;
  EXPECT_EQ(testing::InputErrorOf([&] { ReadGreyImage(claimed); }),
            claimed + ": image is 100000x100000 px (from its header), more than flatscan's limit of 100 million pixels");
  EXPECT_EQ(testing::InputErrorOf([&] { ReadGreyImage(small, cv::Size(2592, 1944)); }),
            small + ": image is 8x8 but the rig was calibrated for 2592x1944: use the images of the calibrated cameras");
  EXPECT_EQ(ReadGreyImage(small, cv::Size(8, 8)).size(), cv::Size(8, 8));
  // A header that lies the other way (a truncated file) is the decoder's to report.
  std::ofstream(dir.path() / "truncated.png", std::ios::binary) << testing::ReadFileBytes(small).substr(0, 40);
  EXPECT_EQ(testing::InputErrorOf([&] { ReadGreyImage((dir.path() / "truncated.png").string()); })
                .rfind((dir.path() / "truncated.png").string() + ": cannot read image", 0),
            0u);
}

// Before: "over-exposed" for a uniform 16-bit image at half range (scaled by its maximum).
TEST(ImageHeader, AUniformSixteenBitImageSaysSo) {
  testing::ScratchDir dir("image-uniform16");
  const std::string path = (dir.path() / "half.png").string();
  ASSERT_TRUE(cv::imwrite(path, cv::Mat_<uint16_t>(20, 30, uint16_t{32768})));
  EXPECT_EQ(testing::InputErrorOf([&] { ReadGreyImage(path); }),
            path + ": uniform 16-bit image (every pixel 32768 of 65535): nothing to measure (expected a dark part on a "
                   "bright backlight)");
}

}  // namespace
}  // namespace flatscan
