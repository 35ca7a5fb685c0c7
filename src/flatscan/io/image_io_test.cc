#include "flatscan/io/image_io.h"

#include <fstream>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <zlib.h>

#include <cstdint>
#include <vector>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

// A PNG chunk: length, type, data, CRC-32 of type and data.
void AppendChunk(std::vector<uchar>& png, const char* type, const std::vector<uchar>& data) {
  for (int shift : {24, 16, 8, 0}) png.push_back(uchar(data.size() >> shift));
  const size_t start = png.size();
  png.insert(png.end(), type, type + 4);
  png.insert(png.end(), data.begin(), data.end());
  const uLong crc = crc32(0L, png.data() + start, uInt(png.size() - start));
  for (int shift : {24, 16, 8, 0}) png.push_back(uchar(crc >> shift));
}

// An 8-bit grey PNG of `image` whose row y uses filter type filters[y % size] (the
// forward filters of the PNG specification, section 9), its data in IDAT chunks of
// `idat_bytes`.
std::vector<uchar> PngWithFilters(const cv::Mat1b& image, const std::vector<int>& filters, size_t idat_bytes = 1 << 20) {
  std::vector<uchar> raw;
  for (int y = 0; y < image.rows; ++y) {
    const int type = filters[size_t(y) % filters.size()];
    raw.push_back(uchar(type));
    for (int x = 0; x < image.cols; ++x) {
      const int a = x > 0 ? image(y, x - 1) : 0, b = y > 0 ? image(y - 1, x) : 0,
                c = x > 0 && y > 0 ? image(y - 1, x - 1) : 0;
      const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
      const int predictor[5] = {0, a, b, (a + b) / 2, pa <= pb && pa <= pc ? a : pb <= pc ? b : c};
      raw.push_back(uchar(image(y, x) - predictor[type < 5 ? type : 0]));  // type 5+: a bad file
    }
  }
  std::vector<uchar> z(compressBound(uLong(raw.size())));
  uLongf z_size = uLongf(z.size());
  compress2(z.data(), &z_size, raw.data(), uLong(raw.size()), 6);
  z.resize(z_size);
  std::vector<uchar> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  std::vector<uchar> ihdr;
  for (uint32_t v : {uint32_t(image.cols), uint32_t(image.rows)})
    for (int shift : {24, 16, 8, 0}) ihdr.push_back(uchar(v >> shift));
  ihdr.insert(ihdr.end(), {8, 0, 0, 0, 0});  // depth 8, grey, deflate, adaptive filters, not interlaced
  AppendChunk(png, "IHDR", ihdr);
  for (size_t at = 0; at < z.size(); at += idat_bytes)
    AppendChunk(png, "IDAT", std::vector<uchar>(z.begin() + long(at), z.begin() + long(std::min(z.size(), at + idat_bytes))));
  AppendChunk(png, "IEND", {});
  return png;
}

cv::Mat1b RandomImage(int rows, int cols, uint64_t seed) {
  cv::Mat1b image(rows, cols);
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  return image;
}

// flatscan's PNG decoder (libdeflate, its own row filters) against the image and OpenCV.
TEST(DecodeGreyPng, EveryRowFilterDecodesExactly) {
  const cv::Mat1b image = RandomImage(37, 53, 5);
  for (const std::vector<int>& filters : std::vector<std::vector<int>>{{0}, {1}, {2}, {3}, {4}, {0, 1, 2, 3, 4}}) {
    const std::vector<uchar> png = PngWithFilters(image, filters, 100);  // several IDAT chunks
    const cv::Mat1b ours = DecodeGreyPng(png, "test.png");
    ASSERT_EQ(ours.size(), image.size());
    EXPECT_EQ(cv::norm(ours, image, cv::NORM_INF), 0) << "filter " << filters[0];
    EXPECT_EQ(cv::norm(ours, cv::imdecode(png, cv::IMREAD_GRAYSCALE), cv::NORM_INF), 0);
  }
  std::vector<uchar> opencv;  // what the simulator and OpenCV-based camera programs write
  cv::imencode(".png", image, opencv);
  EXPECT_EQ(cv::norm(DecodeGreyPng(opencv, "opencv.png"), image, cv::NORM_INF), 0);
}

TEST(DecodeGreyPng, OtherPngsAreLeftToOpenCvAndCorruptDataNamed) {
  std::vector<uchar> sixteen;
  cv::imencode(".png", cv::Mat1w(8, 8, ushort{1000}), sixteen);
  EXPECT_TRUE(DecodeGreyPng(sixteen, "16.png").empty());
  std::vector<uchar> colour;
  cv::imencode(".png", cv::Mat3b(8, 8, cv::Vec3b(1, 2, 3)), colour);
  EXPECT_TRUE(DecodeGreyPng(colour, "rgb.png").empty());

  const cv::Mat1b image = RandomImage(20, 30, 6);
  std::vector<uchar> png = PngWithFilters(image, {4});
  std::vector<uchar> garbled = png;
  garbled[41 + 10] ^= 0xFF;  // inside the zlib stream of the first IDAT
  EXPECT_EQ(testing::InputErrorOf([&] { DecodeGreyPng(garbled, "g.png"); }),
            "g.png: cannot read image (corrupt PNG: its image data are not a valid zlib stream)");
  const std::vector<uchar> wrong_size = PngWithFilters(RandomImage(19, 30, 6), {4});
  std::vector<uchar> lying = wrong_size;
  lying[23] = 20;  // the header now says 20 rows, the data hold 19
  EXPECT_EQ(testing::InputErrorOf([&] { DecodeGreyPng(lying, "l.png"); }),
            "l.png: cannot read image (corrupt PNG: its image data inflate to 589 bytes, 30x20 px need 620)");
  EXPECT_EQ(testing::InputErrorOf([&] { DecodeGreyPng(PngWithFilters(image, {0, 7}), "f.png"); }),
            "f.png: cannot read image (corrupt PNG: row 1 has filter type 7 (expected 0 to 4))");
}

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
