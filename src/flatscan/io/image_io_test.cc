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
}

// Before: libpng printed "libpng error: Read Error" or "IDAT: CRC error" without the
// file's name, and flatscan added "cannot read image". A file copied while it was still
// being written, or damaged on the way, now says which chunk is short or corrupt.
TEST(ImageHeader, TruncatedOrCorruptPngFilesNameTheirDamage) {
  testing::ScratchDir dir("image-damaged");
  const std::string whole = (dir.path() / "whole.png").string();
  cv::Mat1b pattern(64, 64);
  cv::randu(pattern, 0, 256);  // does not compress: IDAT is the largest chunk
  ASSERT_TRUE(cv::imwrite(whole, pattern));
  const std::string bytes = testing::ReadFileBytes(whole);
  ASSERT_GT(bytes.size(), 4096u);
  const auto write = [&](const std::string& name, const std::string& content) {
    const std::string path = (dir.path() / name).string();
    std::ofstream(path, std::ios::binary) << content;
    return path;
  };
  // Signature (8) + IHDR (12 + 13) = 33: the IDAT chunk starts at byte 33.
  const std::string cut = write("cut.png", bytes.substr(0, 2000));
  const uint32_t idat_bytes = (static_cast<unsigned char>(bytes[33]) << 24 | static_cast<unsigned char>(bytes[34]) << 16 |
                               static_cast<unsigned char>(bytes[35]) << 8 | static_cast<unsigned char>(bytes[36]));
  ASSERT_EQ(bytes.substr(37, 4), "IDAT");
  EXPECT_EQ(testing::InputErrorOf([&] { ReadGreyImage(cut); }),
            fmt::format("{}: truncated PNG: chunk IDAT at byte 33 needs {} bytes, only 1967 are left (expected a "
                        "complete 8-bit grey PNG file)",
                        cut, idat_bytes + 12));
  const std::string headless = write("headless.png", bytes.substr(0, 40));
  EXPECT_EQ(testing::InputErrorOf([&] { ReadGreyImage(headless); }),
            headless + ": truncated PNG: the file ends after 40 bytes without its IEND chunk (expected a complete "
                       "8-bit grey PNG file)");
  std::string flipped = bytes;
  flipped[1000] = static_cast<char>(flipped[1000] ^ 0x10);  // one bit inside IDAT's data
  const std::string corrupt = write("corrupt.png", flipped);
  EXPECT_EQ(testing::InputErrorOf([&] { ReadGreyImage(corrupt); }),
            corrupt + ": damaged PNG: chunk IDAT at byte 33 fails its CRC check (expected a complete 8-bit grey PNG "
                      "file)");
  EXPECT_EQ(ReadGreyImage(whole).size(), cv::Size(64, 64));
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
