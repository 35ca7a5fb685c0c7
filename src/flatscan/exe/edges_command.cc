#include <algorithm>
#include <filesystem>
#include <iostream>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

#include "flatscan/boundary/boundary.h"
#include "flatscan/boundary/boundary_report.h"
#include "flatscan/evaluation/edge_accuracy.h"
#include "flatscan/exe/commands.h"
#include "flatscan/exe/options.h"
#include "flatscan/io/atomic_output.h"
#include "flatscan/io/image_io.h"
#include "flatscan/io/output_files.h"
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
        ->check(IntegerIn(1, 8));
    sub_->add_option("--method", method_, "blur-model (ours), zernike (plain Ghosal-Mehrotra) or canny (pixel level)")
        ->check(CLI::IsMember({"blur-model", "zernike", "canny"}))
        ->default_val("blur-model");
    sub_->add_flag("--whole-image", whole_image_,
                   "search the whole image (textured scenes) instead of a band around the part");
    AddBlurOption(sub_, &blur_);
  }

  int Run() override {
    if (!overlay_.empty() && !cv::haveImageWriter(overlay_))
      ThrowInputError("{}: unknown image format for --overlay (use .png, .jpg, .bmp or .tif)", overlay_);
    OutputFiles out({{"image", image_}});
    out.Declare("--csv", csv_, OutputFiles::kStdoutAllowed);
    out.Declare("--overlay", overlay_);
    const cv::Mat1b image = ReadEdgesInputImage(image_);
    BoundaryOptions options;
    options.method = method_ == "canny"     ? EdgeMethod::kCannyPixel
                     : method_ == "zernike" ? EdgeMethod::kZernike
                                            : EdgeMethod::kBlurModel;
    options.restrict_to_part = !whole_image_;
    options.blur_sigma_px = blur_;
    const BoundaryResult result = DetectBoundary(image, options);
    if (result.points.empty()) spdlog::warn("{}: no edge found; the CSV has only its header", image_);
    out.StageText("--csv", BoundaryPointsCsv(result));
    if (!overlay_.empty()) {
      const int scale =
          overlay_scale_ > 0 ? overlay_scale_ : std::clamp(1024 / std::max(image.cols, image.rows), 1, 8);
      const cv::Mat3b overlay = DrawBoundaryOverlay(image, result, scale);
      out.Stage("--overlay", [&](const std::filesystem::path& tmp) {
        if (!cv::imwrite(tmp.string(), overlay)) ThrowInputError("cannot write '{}'", overlay_);
      });
    }
    out.Commit();
    (csv_ == "-" ? std::cerr : std::cout) << fmt::format("{}: {} points in {} contours ({}, blur sigma {:.2f} px, {} edge pixels) -> {}\n",
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
