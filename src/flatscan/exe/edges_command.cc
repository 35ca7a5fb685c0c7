#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "flatscan/boundary/boundary.h"
#include "flatscan/evaluation/edge_accuracy.h"
#include "flatscan/exe/commands.h"
#include "flatscan/io/atomic_output.h"
#include "flatscan/io/image_io.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

constexpr int kWindow = 7;  // the Zernike operator's window

// Reads `path` as 8-bit grey (io/image_io.h) and checks it can hold the operator.
cv::Mat1b ReadEdgesInputImage(const std::string& path) {
  cv::Mat1b image = ReadGreyImage(path);
  if (image.cols < kWindow || image.rows < kWindow)
    ThrowInputError("{}: image is {} x {} pixels, smaller than the {} x {} window of the edge operator", path,
                    image.cols, image.rows, kWindow, kWindow);
  return image;
}

std::string PointsCsv(const BoundaryResult& result) {
  fmt::memory_buffer out;
  fmt::format_to(std::back_inserter(out), "x,y,nx,ny,h,contour\n");
  for (const EdgePoint& p : result.points)
    fmt::format_to(std::back_inserter(out), "{:.4f},{:.4f},{:.5f},{:.5f},{:.2f},{}\n", p.x, p.y, p.nx, p.ny,
                   p.step, p.contour);
  return fmt::to_string(out);
}

cv::Scalar ContourColour(int contour) {
  if (contour < 0) return {0, 0, 255};
  const double hue = std::fmod(contour * 0.6180339887, 1.0) * 180.0;
  cv::Mat3b hsv(1, 1, cv::Vec3b(static_cast<uchar>(hue), 255, 255)), bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  const cv::Vec3b c = bgr(0, 0);
  return {double(c[0]), double(c[1]), double(c[2])};
}

// The image upscaled `scale` times (nearest neighbour) with each contour's chain drawn
// in its own colour and a dot on every point. Pixel centre u of the image is at
// scale * u + (scale - 1) / 2 in the overlay.
cv::Mat3b DrawOverlay(const cv::Mat1b& image, const BoundaryResult& result, int scale) {
  cv::Mat3b overlay;
  cv::Mat1b big;
  cv::resize(image, big, cv::Size(), scale, scale, cv::INTER_NEAREST);
  cv::cvtColor(big, overlay, cv::COLOR_GRAY2BGR);
  constexpr int kShift = 4;
  auto to_overlay = [&](const EdgePoint& p) {
    const double f = double(1 << kShift);
    return cv::Point(static_cast<int>(std::lround((scale * p.x + 0.5 * (scale - 1)) * f)),
                     static_cast<int>(std::lround((scale * p.y + 0.5 * (scale - 1)) * f)));
  };
  std::map<int, cv::Scalar> colours;
  auto colour_of = [&](int contour) {
    auto it = colours.find(contour);
    if (it == colours.end()) it = colours.emplace(contour, ContourColour(contour)).first;
    return it->second;
  };
  const std::vector<EdgePoint>& points = result.points;
  for (size_t i = 0; i < points.size(); ++i) {
    const cv::Scalar colour = colour_of(points[i].contour);
    if (scale == 1) {
      const int u = static_cast<int>(std::lround(points[i].x)), v = static_cast<int>(std::lround(points[i].y));
      if (u >= 0 && v >= 0 && u < overlay.cols && v < overlay.rows)
        overlay(v, u) = cv::Vec3b(uchar(colour[0]), uchar(colour[1]), uchar(colour[2]));
      continue;
    }
    if (i + 1 < points.size() && points[i + 1].contour == points[i].contour &&
        std::hypot(points[i + 1].x - points[i].x, points[i + 1].y - points[i].y) < 3.0)
      cv::line(overlay, to_overlay(points[i]), to_overlay(points[i + 1]), colour, 1, cv::LINE_AA, kShift);
    cv::circle(overlay, to_overlay(points[i]), std::max(1, scale / 4) << kShift, colour, cv::FILLED, cv::LINE_AA,
               kShift);
  }
  return overlay;
}

class EdgesCommand : public Command {
 public:
  void Register(CLI::App& app) override {
    sub_ = app.add_subcommand("edges",
                              "Detect the sub-pixel boundary of a dark part on a bright field in one image and "
                              "write its points (pixel-centre coordinates, unit normal from dark to bright, step "
                              "height, contour id) as CSV.");
    sub_->footer("Example: flatscan edges parts/part_000_left.png --csv left.csv --overlay left-edges.png");
    sub_->add_option("image", image_, "8-bit grey image (16-bit and colour are converted with a warning)")
        ->required();
    sub_->add_option("--csv", csv_, "output CSV: x,y,nx,ny,h,contour, one point per line")->required();
    sub_->add_option("--overlay", overlay_, "also draw the points on the image into this PNG/JPEG file");
    sub_->add_option("--overlay-scale", overlay_scale_,
                     "overlay upscaling (default: 1024 / the image's larger side, in [1, 8])")
        ->check(CLI::Range(1, 8));
    sub_->add_option("--method", method_, "blur-model (ours), zernike (plain Ghosal-Mehrotra) or canny (pixel level)")
        ->check(CLI::IsMember({"blur-model", "zernike", "canny"}))
        ->default_val("blur-model");
    sub_->add_flag("--whole-image", whole_image_,
                   "search the whole image (textured scenes) instead of a band around the part");
    sub_->add_option("--blur", blur_, "lens blur sigma in px if known (default 0: estimated from the image)")
        ->check(CLI::NonNegativeNumber);
  }

  int Run() override {
    if (!overlay_.empty() && !cv::haveImageWriter(overlay_))
      ThrowInputError("{}: unknown image format for --overlay (use .png, .jpg, .bmp or .tif)", overlay_);
    const cv::Mat1b image = ReadEdgesInputImage(image_);
    BoundaryOptions options;
    options.method = method_ == "canny"     ? EdgeMethod::kCannyPixel
                     : method_ == "zernike" ? EdgeMethod::kZernike
                                            : EdgeMethod::kBlurModel;
    options.restrict_to_part = !whole_image_;
    options.blur_sigma_px = blur_;
    const BoundaryResult result = DetectBoundary(image, options);
    if (result.points.empty()) spdlog::warn("{}: no edge found; the CSV has only its header", image_);
    WriteTextFileAtomically(csv_, PointsCsv(result));
    if (!overlay_.empty()) {
      const int scale =
          overlay_scale_ > 0 ? overlay_scale_ : std::clamp(1024 / std::max(image.cols, image.rows), 1, 8);
      const cv::Mat3b overlay = DrawOverlay(image, result, scale);
      WriteFileAtomically(overlay_, [&](const std::filesystem::path& tmp) {
        if (!cv::imwrite(tmp.string(), overlay)) ThrowInputError("cannot write '{}'", overlay_);
      });
    }
    std::cout << fmt::format("{}: {} points in {} contours ({}, blur sigma {:.2f} px, {} edge pixels) -> {}\n",
                             image_, result.points.size(), result.contours.size(), EdgeMethodName(options.method),
                             result.blur_sigma_px, result.edge_pixels, csv_);
    return 0;
  }

 private:
  std::string image_;
  std::string csv_;
  std::string overlay_;
  int overlay_scale_ = 0;
  std::string method_ = "blur-model";
  bool whole_image_ = false;
  double blur_ = 0.0;
};

}  // namespace

std::unique_ptr<Command> MakeEdgesCommand() { return std::make_unique<EdgesCommand>(); }

}  // namespace flatscan
