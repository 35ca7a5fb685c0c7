#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>
#include <tbb/task_arena.h>

#include "flatscan/exe/commands.h"
#include "flatscan/exe/options.h"
#include "flatscan/inspection/inspection_record.h"
#include "flatscan/inspection/inspection_report.h"
#include "flatscan/io/atomic_output.h"
#include "flatscan/io/image_io.h"
#include "flatscan/io/output_files.h"
#include "flatscan/io/pairs_csv.h"
#include "flatscan/io/rig_file.h"
#include "flatscan/util/error.h"
#include "flatscan/util/ordered_parallel.h"
#include "flatscan/util/sha256.h"

namespace flatscan {
namespace {

class InspectCommand : public Command {
 public:
  void Register(CLI::App& app) override {
    sub_ = app.add_subcommand("inspect", "Measure the flatness of a part from a stereo pair and give the verdict "
                                         "(exit 0 pass, 1 fail, 2 not measured).");
    sub_->footer("Example: flatscan inspect --rig rig.yml --plane plane.yml --left L.png --right R.png "
                 "--thickness 0.2 --tolerance 0.1 --json out.json\n"
                 "Batch:   flatscan inspect --rig rig.yml --plane plane.yml --pairs pairs.csv --thickness 0.2 "
                 "--tolerance 0.1 --json results.jsonl");
    sub_->add_option("--rig", rig_, "rig file (OpenCV YAML: M1 D1 M2 D2 R T ...)")->required();
    sub_->add_option("--plane", plane_, "support plane file (from calibrate-plane)")->required();
    auto* left = sub_->add_option("--left", left_, "left image");
    sub_->add_option("--right", right_, "right image")->needs(left);
    sub_->add_option("--pairs", pairs_,
                     "CSV (RFC 4180) with the columns id,left,right and optionally thickness (mm): measure every pair "
                     "(paths relative to the CSV)")
        ->excludes(left);
    thickness_ = Fills(sub_->add_option("--thickness", params_.thickness_mm,
                                        "height of the part's side face, mm: the sheet thickness (plus the wall "
                                        "height for folded walls); with --pairs, for the pairs without a thickness "
                                        "column")
                           ->check(RealIn(0, 5)),
                       "thickness_mm");
    Fills(AddToleranceOption(sub_, &spec_.tolerance_mm)->required(), "tolerance_mm");
    Fills(sub_->add_option("--guard-band", spec_.guard_band_mm,
                           "measurement uncertainty U, mm (e.g. from `flatscan evaluate`): a flatness within U of the "
                           "tolerance is reported as marginal (the verdict and exit code stay pass/fail)")
              ->default_val(spec_.guard_band_mm)
              ->check(RealIn(0, 1)),
          "guard_band_mm");
    sub_->add_option("--json", json_, "JSON record (batch: one JSON line per part, then a summary line)");
    sub_->add_option("--ply", ply_, "PLY of the valid 3D boundary points with their heights (single pair)");
    sub_->add_option("--overlay", overlay_,
                     "folder for left/right overlay PNGs of the points coloured by height (batch: one folder per part)");
    sub_->add_option("--overlay-scale", overlay_scale_,
                     "scale of the overlay images (a full-size RGB overlay of a 5 MP camera is about 6.4 MB as PNG)")
        ->default_val(overlay_scale_)
        ->check(RealIn(0.05, 1));
    sub_->add_flag("--allow-foreign-plane", allow_foreign_plane_,
                   "measure with a plane file calibrated with another rig file (its rig_sha256 differs): a warning, "
                   "and the JSON says so; the heights may be off by micrometres");
    AddNoThicknessCorrectionFlag(sub_, &no_correction_);
    AddSideFacesOption(sub_, &params_.side_faces);
    AddBlurOption(sub_, &params_.boundary.blur_sigma_px);
  }

  int Run() override {
    if (pairs_.empty() && (left_.empty() || right_.empty()))
      ThrowInputError("inspect: give --left and --right, or --pairs");
    if (!pairs_.empty() && !ply_.empty())
      ThrowInputError("--ply: a PLY is written for a single pair (--left, --right), not for a batch (--pairs)");
    CheckFlatnessSpec(spec_);
    params_.thickness_correction = !no_correction_;
    // Every input is read and every output checked before the first part is measured.
    std::vector<PairEntry> pairs;
    if (!pairs_.empty()) pairs = ReadPairsCsv(pairs_);
    CheckThicknessGiven(pairs);
    OutputFiles out(Inputs(pairs));
    out.Declare("--json", json_, OutputFiles::kStdoutAllowed);
    if (pairs.empty()) {
      out.Declare("--ply", ply_);
      DeclareOverlays(out, overlay_);
    } else if (!overlay_.empty()) {
      RequireFolderOrNew("--overlay", overlay_);
    }
    const StereoRig rig = ReadRigFile(rig_);
    const PlaneFile plane_file = ReadPlaneFile(plane_);
    InspectionInputs base{"", rig_, plane_, "", "", Sha256HexOfFile(rig_), Sha256HexOfFile(plane_)};
    base.plane_rig = CheckPlaneAgainstRig(plane_file, plane_, rig, rig_, base.rig_sha256, allow_foreign_plane_);
    if (base.plane_rig == PlaneRigMatch::kForeign)
      spdlog::warn("{}: calibrated with another rig file than '{}' (--allow-foreign-plane)", plane_, rig_);
    if (base.plane_rig == PlaneRigMatch::kUnknown)
      spdlog::warn("{}: the plane file does not say which rig it was calibrated with (no rig_sha256: written "
                   "before that key existed); recalibrate it with `flatscan calibrate-plane` to have it checked",
                   plane_);
    const SupportPlane& plane = plane_file.plane;
    if (pairs.empty()) return RunOne(rig, plane, base, out);
    return RunBatch(rig, plane, base, pairs, out);
  }

 private:
  // Every part needs its thickness: --thickness, or the pairs file's column for each pair.
  void CheckThicknessGiven(const std::vector<PairEntry>& pairs) const {
    if (thickness_->count() > 0) return;
    if (pairs.empty()) ThrowInputError("--thickness is required (the height of the part's side face, mm)");
    for (const PairEntry& p : pairs)
      if (!p.thickness_mm)
        ThrowInputError("--thickness is required: pair '{}' of {} has no thickness (give --thickness, or a "
                        "thickness column for every pair)",
                        p.id, pairs_);
  }

  // The command's input files: the rig, the plane, the CSV and every image it names.
  std::vector<OutputFiles::Named> Inputs(const std::vector<PairEntry>& pairs) const {
    std::vector<OutputFiles::Named> inputs = {{"--rig", rig_}, {"--plane", plane_}, {"--pairs", pairs_},
                                              {"--left", left_}, {"--right", right_}};
    for (const PairEntry& p : pairs) {
      inputs.emplace_back("--pairs (" + p.id + ")", p.left);
      inputs.emplace_back("--pairs (" + p.id + ")", p.right);
    }
    return inputs;
  }

  static void DeclareOverlays(OutputFiles& out, const std::string& dir) {
    if (dir.empty()) return;
    RequireFolderOrNew("--overlay", dir);
    out.Declare("--overlay (left)", std::filesystem::path(dir) / "left_overlay.png", OutputFiles::kCreateFolder);
    out.Declare("--overlay (right)", std::filesystem::path(dir) / "right_overlay.png", OutputFiles::kCreateFolder);
  }

  static void RequireFolderOrNew(const std::string& option, const std::string& dir) {
    std::error_code ec;
    const auto status = std::filesystem::symlink_status(dir, ec);
    if (std::filesystem::exists(status) && status.type() != std::filesystem::file_type::directory)
      ThrowInputError("{} '{}': exists and is not a folder (the overlays go into a folder)", option, dir);
  }

  static cv::Size SizeOf(const Camera& camera) { return {camera.width, camera.height}; }

  // Stdout carries the JSON when --json is "-"; the summary then goes to stderr.
  std::ostream& Text() const { return json_ == "-" ? std::cerr : std::cout; }

  int RunOne(const StereoRig& rig, const SupportPlane& plane, InspectionInputs inputs, OutputFiles& out) {
    inputs.left_file = left_;
    inputs.right_file = right_;
    // A missing image is a usage error (nothing written); one that cannot be decoded or
    // measured is a part that was not measured, and gets its record.
    for (const std::string& image : {left_, right_})
      if (!std::filesystem::is_regular_file(image)) ThrowInputError("{}: no such file", image);
    cv::Mat1b l, r;
    std::optional<InspectionResult> result;
    InspectionRecord record;
    try {
      l = ReadGreyImage(left_, SizeOf(rig.left));
      r = ReadGreyImage(right_, SizeOf(rig.right));
      result = InspectPart(rig, plane, l, r, params_, left_, right_);
      record = MeasuredRecord(*result, params_, spec_, inputs);
    } catch (const InputError& e) {
      record = NotMeasuredRecord(e.what(), params_, spec_, inputs);
    }
    if (record.measured) PrintSummary(record);
    out.StageText("--json", RecordToJson(record).dump(2) + "\n");
    if (result && !ply_.empty()) out.Stage("--ply", [&](const std::filesystem::path& tmp) { WritePly(tmp.string(), *result); });
    if (result && !overlay_.empty()) StageOverlays(out, l, r, *result);
    out.Commit();
    if (!record.measured) {
      spdlog::error("not measured: {}", record.error);
      return 2;
    }
    return record.judgement.pass() ? 0 : 1;
  }

  // One part of a batch: its record and, for the table, whether it was measured.
  InspectionRecord MeasureBatchPart(const StereoRig& rig, const SupportPlane& plane, const InspectionInputs& base,
                                    const PairEntry& p, const std::string& overlay_name) const {
    InspectionInputs inputs = base;
    inputs.id = p.id;
    inputs.left_file = p.left;
    inputs.right_file = p.right;
    InspectionParams params = params_;
    if (p.thickness_mm) params.thickness_mm = *p.thickness_mm;
    try {
      const cv::Mat1b l = ReadGreyImage(p.left, SizeOf(rig.left)), r = ReadGreyImage(p.right, SizeOf(rig.right));
      const InspectionResult result = InspectPart(rig, plane, l, r, params, p.left, p.right);
      if (!overlay_.empty()) WriteOverlays((std::filesystem::path(overlay_) / overlay_name).string(), l, r, result);
      return MeasuredRecord(result, params, spec_, inputs);
    } catch (const InputError& e) {
      return NotMeasuredRecord(e.what(), params, spec_, inputs);
    }
  }

  // Pairs are measured in parallel and their records streamed in input order: each JSON
  // line is written and flushed as soon as the parts before it are, so a killed batch
  // keeps what it measured; the file is complete when its summary line is there.
  int RunBatch(const StereoRig& rig, const SupportPlane& plane, const InspectionInputs& base,
               const std::vector<PairEntry>& pairs, OutputFiles&) {
    std::ofstream file;
    if (!json_.empty() && json_ != "-") {
      file.open(json_, std::ios::binary | std::ios::trunc);
      if (!file) ThrowInputError("--json '{}': cannot write it", json_);
    }
    std::ostream* lines = json_.empty() ? nullptr : json_ == "-" ? &std::cout : &file;
    if (!overlay_.empty()) {  // made here, not by the parallel workers
      std::error_code ec;
      std::filesystem::create_directories(overlay_, ec);
      if (ec) ThrowInputError("--overlay '{}': cannot create the folder: {}", overlay_, ec.message());
    }
    std::vector<std::string> overlay_names(pairs.size());
    std::set<std::string> taken;
    for (size_t i = 0; i < pairs.size(); ++i) overlay_names[i] = UniqueFileName(SafeFileName(pairs[i].id), &taken);

    int pass = 0, fail = 0, unmeasured = 0, marginal = 0;
    double total_ms = 0;
    const auto start = std::chrono::steady_clock::now();
    auto last_progress = start;
    Text() << fmt::format("{:<24} {:>12} {:>15} {:>10} {:>9}  {}\n", "id", "flatness_mm", "uncertainty_mm", "coverage",
                          "verdict", "note");
    ParallelInOrder<InspectionRecord>(
        pairs.size(), 2 * static_cast<size_t>(tbb::this_task_arena::max_concurrency()),
        [&](size_t i) { return MeasureBatchPart(rig, plane, base, pairs[i], overlay_names[i]); },
        [&](size_t i, InspectionRecord& record) {
          if (record.measured) {
            (record.judgement.pass() ? pass : fail)++;
            marginal += record.judgement.marginal;
            total_ms += record.TotalMs();
            Text() << fmt::format("{:<24} {:>12.4f} {:>15.4f} {:>10.3f} {:>9}  {}\n", record.id,
                                  record.values.flatness_mm, record.uncertainty.expanded_mm, record.coverage,
                                  VerdictName(record.judgement.verdict),
                                  record.judgement.marginal ? "marginal" : "");
          } else {
            ++unmeasured;
            spdlog::error("{}: not measured: {}", record.id, record.error);
            Text() << fmt::format("{:<24} {:>12} {:>15} {:>10} {:>9}  {}\n", record.id, "-", "-", "-", "-", "not measured");
          }
          if (lines) *lines << RecordToJson(record).dump() << "\n" << std::flush;
          const auto now = std::chrono::steady_clock::now();
          if (now - last_progress > std::chrono::seconds(2) || i + 1 == pairs.size()) {
            last_progress = now;
            const double elapsed = std::chrono::duration<double>(now - start).count();
            spdlog::info("batch: part {}/{} ({:.0f} s, about {:.0f} s left)", i + 1, pairs.size(), elapsed,
                         elapsed / static_cast<double>(i + 1) * static_cast<double>(pairs.size() - i - 1));
          }
        });
    const nlohmann::json summary = {{"summary", true},  {"parts", pairs.size()}, {"pass", pass}, {"fail", fail},
                                    {"not_measured", unmeasured}, {"marginal", marginal},
                                    {"mean_time_ms", pass + fail > 0 ? total_ms / (pass + fail) : 0.0}};
    if (lines) *lines << summary.dump() << "\n" << std::flush;
    if (file.is_open()) {
      file.close();
      if (file.fail()) ThrowInputError("--json '{}': write failed", json_);
    }
    Text() << fmt::format("{} parts: {} pass, {} fail, {} not measured{}\n", pairs.size(), pass, fail, unmeasured,
                          fmt::format("; {} marginal (within the larger of the {:.4f} mm guard band and their own "
                                      "uncertainty of the tolerance)",
                                      marginal, spec_.guard_band_mm));
    if (unmeasured > 0) return 2;
    return fail > 0 ? 1 : 0;
  }

  void PrintSummary(const InspectionRecord& r) const {
    Text() << fmt::format(
        "flatness_mm {:.4f}  lsq_pv_mm {:.4f}  minzone_mm {:.4f}\nuncertainty_mm {:.4f} (k = 2: rim {:.4f}, rig {:.4f}, "
        "plane {:.4f}, method {:.4f} mm)\nverdict {} (tolerance {:.3f} mm, thickness {:.3f} mm)\n"
        "points: {} valid of {} matched ({} / {} crossings), coverage {:.3f}{}\ntime {:.1f} ms\n",
        r.values.flatness_mm, r.values.lsq_pv_mm, r.values.minzone_mm, r.uncertainty.expanded_mm, r.uncertainty.rim_mm,
        r.uncertainty.rig_mm, r.uncertainty.plane_mm, r.uncertainty.method_mm,
        std::string(VerdictName(r.judgement.verdict)) +
            (r.judgement.marginal
                 ? fmt::format(" MARGINAL: within the {:.4f} mm guard band or the part's uncertainty of the tolerance",
                               r.spec.guard_band_mm)
                 : ""),
        r.spec.tolerance_mm, r.thickness_mm, r.valid, r.matched, r.crossings_left, r.crossings_right, r.coverage,
        r.completed > 0 ? fmt::format(" ({} outline points completed from the warp fit)", r.completed) : "", r.TotalMs());
  }

  cv::Mat Scaled(const cv::Mat& overlay) const {
    if (overlay_scale_ >= 1) return overlay;
    cv::Mat small;
    cv::resize(overlay, small, cv::Size(), overlay_scale_, overlay_scale_, cv::INTER_AREA);
    return small;
  }

  void StageOverlays(OutputFiles& out, const cv::Mat1b& l, const cv::Mat1b& r, const InspectionResult& result) const {
    out.Stage("--overlay (left)", [&](const std::filesystem::path& tmp) {
      WriteImage(tmp.string(), Scaled(DrawHeightOverlay(l, result, RigSide::kLeft, spec_)));
    });
    out.Stage("--overlay (right)", [&](const std::filesystem::path& tmp) {
      WriteImage(tmp.string(), Scaled(DrawHeightOverlay(r, result, RigSide::kRight, spec_)));
    });
  }

  void WriteOverlays(const std::string& dir, const cv::Mat1b& l, const cv::Mat1b& r, const InspectionResult& result) const {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) ThrowInputError("cannot create folder '{}': {}", dir, ec.message());
    WriteImage((std::filesystem::path(dir) / "left_overlay.png").string(),
               Scaled(DrawHeightOverlay(l, result, RigSide::kLeft, spec_)));
    WriteImage((std::filesystem::path(dir) / "right_overlay.png").string(),
               Scaled(DrawHeightOverlay(r, result, RigSide::kRight, spec_)));
  }

  CLI::Option* thickness_ = nullptr;
  double overlay_scale_ = 1.0;
  std::string rig_, plane_, left_, right_, pairs_, json_, ply_, overlay_;
  bool no_correction_ = false, allow_foreign_plane_ = false;
  InspectionParams params_;
  FlatnessSpec spec_;
};

}  // namespace

std::unique_ptr<Command> MakeInspectCommand() { return std::make_unique<InspectCommand>(); }

}  // namespace flatscan
