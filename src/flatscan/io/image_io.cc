#include "flatscan/io/image_io.h"

#include <algorithm>
#include <climits>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>
#include <libdeflate.h>
#include <zlib.h>

#include "flatscan/io/atomic_output.h"
#include "flatscan/util/error.h"
#include "flatscan/util/sha256.h"

namespace flatscan {

namespace {

constexpr unsigned char kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};

uint32_t BigEndian(const unsigned char* p, int bytes) {
  uint32_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}
uint32_t LittleEndian(const unsigned char* p, int bytes) {
  uint32_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

// JPEG: the first start-of-frame marker (SOF0..SOF15 but DHT C4, JPG C8, DAC CC) holds
// height and width after its length and precision.
std::optional<cv::Size> JpegSize(std::ifstream& in) {
  in.seekg(2);
  unsigned char m[9];
  while (in.read(reinterpret_cast<char*>(m), 4)) {
    if (m[0] != 0xFF) return std::nullopt;
    const int marker = m[1];
    const uint32_t length = BigEndian(m + 2, 2);
    if (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC) {
      if (!in.read(reinterpret_cast<char*>(m), 5)) return std::nullopt;
      return cv::Size(static_cast<int>(BigEndian(m + 3, 2)), static_cast<int>(BigEndian(m + 1, 2)));
    }
    if (length < 2) return std::nullopt;
    in.seekg(length - 2, std::ios::cur);
  }
  return std::nullopt;
}

// PGM/PPM (P2, P3, P5, P6): magic, then width and height as decimal text (comments skipped).
std::optional<cv::Size> NetpbmSize(std::ifstream& in) {
  in.seekg(2);
  long long dims[2];
  for (long long& d : dims) {
    in >> std::ws;
    while (in.peek() == '#') {
      std::string comment;
      std::getline(in, comment);
      in >> std::ws;
    }
    if (!(in >> d) || d <= 0 || d > (1LL << 31) - 1) return std::nullopt;
  }
  return cv::Size(static_cast<int>(dims[0]), static_cast<int>(dims[1]));
}

// TIFF: the first image file directory's ImageWidth (256) and ImageLength (257) tags.
std::optional<cv::Size> TiffSize(std::ifstream& in, bool little) {
  const auto read = [&](std::streamoff at, int bytes) -> std::optional<uint32_t> {
    unsigned char b[4];
    in.clear();
    in.seekg(at);
    if (!in.read(reinterpret_cast<char*>(b), bytes)) return std::nullopt;
    return little ? LittleEndian(b, bytes) : BigEndian(b, bytes);
  };
  const std::optional<uint32_t> ifd = read(4, 4);
  if (!ifd) return std::nullopt;
  const std::optional<uint32_t> entries = read(*ifd, 2);
  if (!entries || *entries > 4096) return std::nullopt;
  uint32_t width = 0, height = 0;
  for (uint32_t e = 0; e < *entries; ++e) {
    const std::streamoff at = static_cast<std::streamoff>(*ifd) + 2 + 12 * static_cast<std::streamoff>(e);
    const std::optional<uint32_t> tag = read(at, 2), type = read(at + 2, 2);
    if (!tag || !type) return std::nullopt;
    const std::optional<uint32_t> value = read(at + 8, *type == 3 ? 2 : 4);  // SHORT or LONG
    if (!value) return std::nullopt;
    if (*tag == 256) width = *value;
    if (*tag == 257) height = *value;
  }
  if (width == 0 || height == 0) return std::nullopt;
  return cv::Size(static_cast<int>(std::min<uint32_t>(width, INT32_MAX)),
                  static_cast<int>(std::min<uint32_t>(height, INT32_MAX)));
}

// What is wrong with a PNG file's chunk structure, or nullopt when every chunk is
// whole, passes its CRC-32 and the file ends with IEND (or when it is not a PNG file). Checked before decoding because
// libpng prints its own "libpng error: Read Error" (a truncated file: one copied while it
// was still being written) or "IDAT: CRC error" to stderr, without the file's name,
// before OpenCV returns an empty image. A chunk is a 4-byte big-endian length, a 4-byte
// type, the data and a CRC-32 of type and data (PNG specification, section 5.3).
std::optional<std::string> PngChunkDamage(const std::vector<unsigned char>& file) {
  if (file.size() < 8 || !std::equal(kPngSignature, kPngSignature + 8, file.begin())) return std::nullopt;
  constexpr uint32_t kMaxChunkBytes = 0x7FFFFFFF;  // the specification's limit, 2^31 - 1
  const uintmax_t file_bytes = file.size();
  uintmax_t at = 8;  // after the signature
  while (at + 12 <= file_bytes) {
    const unsigned char* head = &file[at];
    const uint32_t length = BigEndian(head, 4);
    const std::string type(reinterpret_cast<const char*>(head + 4), 4);
    if (length > kMaxChunkBytes || at + 12 + length > file_bytes)
      return fmt::format("truncated PNG: chunk {} at byte {} needs {} bytes, only {} are left", type, at,
                         12 + static_cast<uintmax_t>(length), file_bytes - at);
    const uLong crc = crc32(crc32(0L, head + 4, 4), head + 8, length);
    if (BigEndian(head + 8 + length, 4) != crc)
      return fmt::format("damaged PNG: chunk {} at byte {} fails its CRC check", type, at);
    at += 12 + static_cast<uintmax_t>(length);
    if (type == "IEND") return std::nullopt;
  }
  return fmt::format("truncated PNG: the file ends after {} bytes without its IEND chunk", file_bytes);
}

// The header was read apart from the bytes decoded: a file replaced in between must still
// have the expected size.
void CheckDecodedSize(const std::string& path, const cv::Size& decoded, const cv::Size& expected) {
  if (!expected.empty() && decoded != expected)
    ThrowInputError("{}: image is {}x{} but the rig was calibrated for {}x{}: use the images of the calibrated cameras",
                    path, decoded.width, decoded.height, expected.width, expected.height);
}

// The file's bytes, bounded by what its pixels can need (8 bytes a pixel: 16-bit RGBA
// uncompressed, plus 1 MB of metadata), so that a file padded to gigabytes is refused
// before it is read.
std::vector<unsigned char> ReadWholeFile(const std::string& path, const cv::Size& size) {
  std::error_code ec;
  const uintmax_t bytes = std::filesystem::file_size(path, ec);
  const uintmax_t limit = 8 * uintmax_t(size.width) * uintmax_t(size.height) + (1u << 20);
  if (ec) ThrowInputError("{}: cannot read image ({})", path, ec.message());
  if (bytes > limit)
    ThrowInputError("{}: the file has {} bytes, more than a {}x{} image needs (at most {})", path, bytes, size.width,
                    size.height, limit);
  std::vector<unsigned char> data(bytes);
  std::ifstream in(path, std::ios::binary);
  if (!in.read(reinterpret_cast<char*>(data.data()), std::streamsize(bytes)))
    ThrowInputError("{}: cannot read image (the file could not be read to its end)", path);
  return data;
}

// Undoes a PNG row filter (specification, section 9) for 1 byte per pixel: `row` is the
// filtered row, `above` the previous decoded row (zeros for the first). Each output byte
// is the filtered byte plus a predictor from a (left), b (above) and c (above-left), all
// mod 256: 0 none, 1 a, 2 b, 3 floor((a + b) / 2), 4 Paeth (whichever of a, b, c is
// nearest to a + b - c, ties in that order). False for an unknown filter type.
bool UnfilterRow(unsigned char type, const unsigned char* row, const unsigned char* above, unsigned char* out,
                 uint32_t width) {
  switch (type) {
    case 0:
      std::copy(row, row + width, out);
      return true;
    case 1:
      for (uint32_t x = 0, a = 0; x < width; ++x) a = out[x] = static_cast<unsigned char>(row[x] + a);
      return true;
    case 2:
      for (uint32_t x = 0; x < width; ++x) out[x] = static_cast<unsigned char>(row[x] + above[x]);
      return true;
    case 3:
      for (uint32_t x = 0, a = 0; x < width; ++x) a = out[x] = static_cast<unsigned char>(row[x] + ((a + above[x]) >> 1));
      return true;
    case 4:
      for (uint32_t x = 0; x < width; ++x) {
        const int a = x > 0 ? out[x - 1] : 0, b = above[x], c = x > 0 ? above[x - 1] : 0;
        const int pa = std::abs(b - c), pb = std::abs(a - c), pc = std::abs(a + b - 2 * c);
        const int predictor = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
        out[x] = static_cast<unsigned char>(row[x] + predictor);
      }
      return true;
    default:
      return false;
  }
}

}  // namespace

std::optional<cv::Size> ReadImageHeaderSize(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char h[26] = {};
  if (!in.read(reinterpret_cast<char*>(h), sizeof(h))) in.clear();
  if (std::equal(kPngSignature, kPngSignature + 8, h) && std::equal(h + 12, h + 16, "IHDR"))
    return cv::Size(static_cast<int>(std::min<uint32_t>(BigEndian(h + 16, 4), INT32_MAX)),
                    static_cast<int>(std::min<uint32_t>(BigEndian(h + 20, 4), INT32_MAX)));
  if (h[0] == 'B' && h[1] == 'M') {  // BITMAPINFOHEADER: signed width, height (negative: top-down)
    const int32_t w = static_cast<int32_t>(LittleEndian(h + 18, 4)), hh = static_cast<int32_t>(LittleEndian(h + 22, 4));
    auto magnitude = [](int32_t v) { return v == INT32_MIN ? INT32_MAX : std::abs(v); };  // -INT32_MIN overflows
    return cv::Size(magnitude(w), magnitude(hh));
  }
  if (h[0] == 0xFF && h[1] == 0xD8) return JpegSize(in);
  if (h[0] == 'P' && (h[1] == '2' || h[1] == '3' || h[1] == '5' || h[1] == '6')) return NetpbmSize(in);
  if ((h[0] == 'I' && h[1] == 'I' && h[2] == 42 && h[3] == 0) || (h[0] == 'M' && h[1] == 'M' && h[2] == 0 && h[3] == 42))
    return TiffSize(in, h[0] == 'I');
  return std::nullopt;
}

cv::Mat1b DecodeGreyPng(const std::vector<unsigned char>& bytes, const std::string& name) {
  const auto corrupt = [&](const std::string& why) {
    ThrowInputError("{}: cannot read image (corrupt PNG: {})", name, why);
  };
  // The chunks: IHDR first (width, height, bit depth, colour type, interlace), the image
  // data in one or more IDAT chunks, which together are one zlib stream.
  if (bytes.size() < 33 || !std::equal(kPngSignature, kPngSignature + 8, bytes.begin()) ||
      !std::equal(bytes.begin() + 12, bytes.begin() + 16, "IHDR"))
    corrupt("no IHDR chunk after the signature");
  if (BigEndian(&bytes[8], 4) != 13) corrupt("its IHDR chunk is not 13 bytes long");
  const uint32_t width = BigEndian(&bytes[16], 4), height = BigEndian(&bytes[20], 4);
  const bool grey8 = bytes[24] == 8 && bytes[25] == 0 && bytes[28] == 0;  // depth 8, grey, not interlaced
  if (!grey8) return {};
  if (bytes[26] != 0 || bytes[27] != 0) corrupt("its IHDR names a compression or filter method other than 0");
  if (width == 0 || height == 0 || uint64_t(width) * height > uint64_t(kMaxImagePixels))
    corrupt(fmt::format("its header says {}x{} px", width, height));
  std::vector<unsigned char> compressed;
  for (size_t at = 8; at + 12 <= bytes.size();) {
    const uint32_t length = BigEndian(&bytes[at], 4);
    if (length > bytes.size() - at - 12) corrupt(fmt::format("chunk at byte {} runs past the end of the file", at));
    if (std::equal(bytes.begin() + at + 4, bytes.begin() + at + 8, "IDAT"))
      compressed.insert(compressed.end(), bytes.begin() + at + 8, bytes.begin() + at + 8 + length);
    if (std::equal(bytes.begin() + at + 4, bytes.begin() + at + 8, "IEND")) break;
    at += 12 + size_t(length);
  }
  // Inflate: every row is its filter type and `width` bytes.
  const size_t row_bytes = size_t(width) + 1;
  std::vector<unsigned char> filtered(row_bytes * height);
  thread_local std::unique_ptr<libdeflate_decompressor, void (*)(libdeflate_decompressor*)> inflater(
      libdeflate_alloc_decompressor(), libdeflate_free_decompressor);
  if (!inflater) throw std::bad_alloc();
  size_t inflated = 0;
  const libdeflate_result rc = libdeflate_zlib_decompress(inflater.get(), compressed.data(), compressed.size(),
                                                          filtered.data(), filtered.size(), &inflated);
  if (rc != LIBDEFLATE_SUCCESS || inflated != filtered.size())
    corrupt(rc == LIBDEFLATE_SUCCESS ? fmt::format("its image data inflate to {} bytes, {}x{} px need {}", inflated,
                                                   width, height, filtered.size())
                                     : std::string("its image data are not a valid zlib stream"));
  cv::Mat1b image(static_cast<int>(height), static_cast<int>(width));
  const std::vector<unsigned char> zero_row(width, 0);
  for (uint32_t y = 0; y < height; ++y) {
    const unsigned char* row = &filtered[y * row_bytes];
    if (!UnfilterRow(row[0], row + 1, y == 0 ? zero_row.data() : image.ptr(int(y) - 1), image.ptr(int(y)), width))
      corrupt(fmt::format("row {} has filter type {} (expected 0 to 4)", y, row[0]));
  }
  return image;
}

namespace {
HashedImage ReadGrey(const std::string& path, const cv::Size& expected, bool hash);
}  // namespace

cv::Mat1b ReadGreyImage(const std::string& path, const cv::Size& expected) {
  return ReadGrey(path, expected, false).image;
}

HashedImage ReadGreyImageHashed(const std::string& path, const cv::Size& expected) {
  return ReadGrey(path, expected, true);
}

namespace {
HashedImage ReadGrey(const std::string& path, const cv::Size& expected, bool hash) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) ThrowInputError("{}: no such file", path);
  if (std::filesystem::is_directory(path, ec)) ThrowInputError("{}: is a folder, not an image", path);
  // Only formats whose header says the size are decoded: OpenCV also decodes JPEG 2000,
  // WebP, OpenEXR and more by their content (the image fuzzer reached JPEG 2000 from a
  // mutated PNG), each bounded only by its own limit of 2^30 pixels.
  const std::optional<cv::Size> header = ReadImageHeaderSize(path);
  if (!header)
    ThrowInputError("{}: cannot read image (expected an 8-bit grey PNG, JPEG, BMP, TIFF or PGM file)", path);
  {
    if (static_cast<long long>(header->width) * header->height > kMaxImagePixels)
      ThrowInputError("{}: image is {}x{} px (from its header), more than flatscan's limit of {} million pixels",
                      path, header->width, header->height, kMaxImagePixels / 1'000'000);
    if (!expected.empty() && *header != expected)
      ThrowInputError("{}: image is {}x{} but the rig was calibrated for {}x{}: use the images of the calibrated "
                      "cameras",
                      path, header->width, header->height, expected.width, expected.height);
  }
  // From here on, the bytes of one read: checked, hashed and decoded.
  const std::vector<unsigned char> bytes = ReadWholeFile(path, *header);
  if (const auto damage = PngChunkDamage(bytes))
    ThrowInputError("{}: {} (expected a complete 8-bit grey PNG file)", path, *damage);
  HashedImage out;
  if (hash) out.sha256 = Sha256Hex(bytes.data(), bytes.size());
  const bool png = bytes.size() >= 8 && std::equal(kPngSignature, kPngSignature + 8, bytes.begin());
  cv::Mat image = png ? DecodeGreyPng(bytes, path) : cv::Mat1b();
  if (!image.empty()) {
    CheckDecodedSize(path, image.size(), expected);
    out.image = image;
    return out;
  }
  try {
    image = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    ThrowInputError("{}: cannot read image ({})", path, e.msg);
  }
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
    double min_value = 0.0, max_value = 0.0;
    cv::minMaxLoc(image, &min_value, &max_value);
    // Scaled by its maximum, a uniform image would read as saturated ("over-exposed").
    if (min_value == max_value)
      ThrowInputError("{}: uniform 16-bit image (every pixel {} of 65535): nothing to measure (expected a dark part "
                      "on a bright backlight)",
                      path, max_value);
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
  CheckDecodedSize(path, image.size(), expected);
  out.image = image;
  return out;
}
}  // namespace

void WriteImage(const std::string& path, const cv::Mat& image) {
  WriteFileAtomically(path, [&](const std::filesystem::path& tmp) {
    if (!cv::imwrite(tmp.string(), image)) ThrowInputError("cannot write image '{}'", path);
  });
}

}  // namespace flatscan
