#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "flatscan/exe/commands.h"
#include "flatscan/inspection/inspection_report.h"
#include "flatscan/io/atomic_output.h"
#include "flatscan/io/image_io.h"
#include "flatscan/io/rig_file.h"
#include "flatscan/util/error.h"
#include "flatscan/util/sha256.h"

namespace flatscan {
namespace {

struct PairEntry {
  std::string id, left, right;
};

// id,left,right with paths relative to the CSV's folder.
std::vector<PairEntry> ReadPairsCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) ThrowInputError("{}: cannot open pairs file (expected a CSV with columns id,left,right)", path);
  const std::filesystem::path base = std::filesystem::path(path).parent_path();
  std::vector<PairEntry> out;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    std::vector<std::string> cols;
    std::stringstream s(line);
    for (std::string c; std::getline(s, c, ',');) cols.push_back(c);
    if (number == 1 && cols.size() == 3 && cols[0] == "id") continue;
    if (cols.size() != 3)
      ThrowInputError("{}: line {} has {} columns (expected 3: id,left,right)", path, number, cols.size());
    auto resolve = [&](const std::string& p) { return std::filesystem::path(p).is_absolute() ? p : (base / p).string(); };
    out.push_back({cols[0], resolve(cols[1]), resolve(cols[2])});
  }
  if (out.empty()) ThrowInputError("{}: no pairs listed (expected lines id,left,right)", path);
  return out;
}

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
    sub_->add_option("--pairs", pairs_, "CSV id,left,right: measure every pair (paths relative to the CSV)")->excludes(left);
    sub_->add_option("--thickness", params_.thickness_mm,
                     "height of the part's side face, mm: the sheet thickness (plus the wall height for folded walls)")
        ->required()->check(CLI::NonNegativeNumber);
    sub_->add_option("--tolerance", params_.tolerance_mm, "flatness tolerance, mm (fail above it)")->required()->check(CLI::PositiveNumber);
    sub_->add_option("--json", json_, "JSON result (batch: one JSON line per part, then a summary line)");
    sub_->add_option("--ply", ply_, "PLY of the valid 3D boundary points with their heights (single pair)");
    sub_->add_option("--overlay", overlay_, "folder for left/right overlay PNGs of the points coloured by height");
    sub_->add_option("--guard-band", guard_band_mm_,
                     "measurement uncertainty U, mm (e.g. from `flatscan evaluate`): a flatness within U of the "
                     "tolerance is reported as marginal (the verdict and exit code stay pass/fail)")
        ->check(CLI::NonNegativeNumber);
    sub_->add_flag("--no-thickness-correction", no_correction_, "triangulate silhouettes as if the sheet had no thickness");
    sub_->add_option("--blur", params_.boundary.blur_sigma_px, "lens blur sigma in px if known (default: estimated)");
  }

  int Run() override {
    if (pairs_.empty() && (left_.empty() || right_.empty()))
      ThrowInputError("inspect: give --left and --right, or --pairs");
    params_.thickness_correction = !no_correction_;
    const StereoRig rig = ReadRigFile(rig_);
    const SupportPlane plane = ReadPlaneFile(plane_);
    InspectionInputs base{"", rig_, plane_, "", "", Sha256HexOfFile(rig_), Sha256HexOfFile(plane_)};
    if (pairs_.empty()) return RunOne(rig, plane, base);
    return RunBatch(rig, plane, base);
  }

 private:
  int RunOne(const StereoRig& rig, const SupportPlane& plane, InspectionInputs inputs) {
    inputs.left_file = left_;
    inputs.right_file = right_;
    const cv::Mat1b l = ReadGreyImage(left_), r = ReadGreyImage(right_);
    const InspectionResult result = InspectPart(rig, plane, l, r, params_, left_, right_);
    PrintSummary(result);
    if (!json_.empty()) WriteTextFileAtomically(json_, Record(result, inputs).dump(2) + "\n");
    if (!ply_.empty()) WritePly(ply_, result);
    if (!overlay_.empty()) WriteOverlays(overlay_, l, r, result);
    return result.pass ? 0 : 1;
  }

  int RunBatch(const StereoRig& rig, const SupportPlane& plane, const InspectionInputs& base) {
    const std::vector<PairEntry> pairs = ReadPairsCsv(pairs_);
    std::string lines;
    int pass = 0, fail = 0, unmeasured = 0, marginal = 0;
    double total_ms = 0;
    std::cout << fmt::format("{:<24} {:>12} {:>10} {:>9}  {}\n", "id", "flatness_mm", "coverage", "verdict", "note");
    for (const PairEntry& p : pairs) {
      InspectionInputs inputs = base;
      inputs.id = p.id;
      inputs.left_file = p.left;
      inputs.right_file = p.right;
      nlohmann::json record;
      try {
        const cv::Mat1b l = ReadGreyImage(p.left), r = ReadGreyImage(p.right);
        const InspectionResult result = InspectPart(rig, plane, l, r, params_, p.left, p.right);
        record = Record(result, inputs);
        (result.pass ? pass : fail)++;
        marginal += IsMarginal(result);
        total_ms += record["timing_ms"]["total"].get<double>();
        std::cout << fmt::format("{:<24} {:>12.4f} {:>10.3f} {:>9}  {}\n", p.id, result.values.flatness_mm, result.coverage,
                                 result.pass ? "pass" : "fail", IsMarginal(result) ? "marginal" : "");
        if (!overlay_.empty()) WriteOverlays((std::filesystem::path(overlay_) / p.id).string(), l, r, result);
      } catch (const InputError& e) {
        ++unmeasured;
        record = NotMeasuredJson(e.what(), inputs);
        spdlog::error("{}: not measured: {}", p.id, e.what());
        std::cout << fmt::format("{:<24} {:>12} {:>10} {:>9}  {}\n", p.id, "-", "-", "-", "not measured");
      }
      lines += record.dump() + "\n";
    }
    const nlohmann::json summary = {{"summary", true},  {"parts", pairs.size()}, {"pass", pass}, {"fail", fail},
                                    {"not_measured", unmeasured}, {"marginal", marginal},
                                    {"mean_time_ms", pass + fail > 0 ? total_ms / (pass + fail) : 0.0}};
    lines += summary.dump() + "\n";
    std::cout << fmt::format("{} parts: {} pass, {} fail, {} not measured{}\n", pairs.size(), pass, fail, unmeasured,
                             guard_band_mm_ >= 0 ? fmt::format("; {} marginal (within {:.4f} mm of the tolerance)", marginal, guard_band_mm_) : "");
    if (!json_.empty()) WriteTextFileAtomically(json_, lines);
    if (unmeasured > 0) return 2;
    return fail > 0 ? 1 : 0;
  }

  void PrintSummary(const InspectionResult& r) const {
    double total = 0;
    for (const auto& [stage, ms] : r.timing_ms) total += ms;
    std::cout << fmt::format(
        "flatness_mm {:.4f}  lsq_pv_mm {:.4f}  minzone_mm {:.4f}\nverdict {} (tolerance {:.3f} mm, thickness {:.3f} mm)\n"
        "points: {} valid of {} matched ({} / {} crossings), coverage {:.3f}{}\ntime {:.1f} ms\n",
        r.values.flatness_mm, r.values.lsq_pv_mm, r.values.minzone_mm,
        std::string(r.pass ? "pass" : "fail") +
            (IsMarginal(r) ? fmt::format(" MARGINAL: within the {:.4f} mm guard band", guard_band_mm_) : ""),
        params_.tolerance_mm,
        params_.thickness_mm, r.valid, r.matched, r.crossings_left, r.crossings_right, r.coverage,
        r.completed > 0 ? fmt::format(" ({} outline points completed from the warp fit)", r.completed) : "", total);
  }

  void WriteOverlays(const std::string& dir, const cv::Mat1b& l, const cv::Mat1b& r, const InspectionResult& result) const {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) ThrowInputError("cannot create folder '{}': {}", dir, ec.message());
    WriteImage((std::filesystem::path(dir) / "left_overlay.png").string(), DrawHeightOverlay(l, result, 0, params_.tolerance_mm));
    WriteImage((std::filesystem::path(dir) / "right_overlay.png").string(), DrawHeightOverlay(r, result, 1, params_.tolerance_mm));
  }

  // With --guard-band: |flatness - tolerance| <= U.
  bool IsMarginal(const InspectionResult& r) const {
    return guard_band_mm_ >= 0 && std::abs(r.values.flatness_mm - params_.tolerance_mm) <= guard_band_mm_;
  }

  nlohmann::json Record(const InspectionResult& result, const InspectionInputs& inputs) const {
    nlohmann::json record = InspectionToJson(result, params_, inputs);
    if (guard_band_mm_ >= 0) {
      record["guard_band_mm"] = guard_band_mm_;
      record["marginal"] = IsMarginal(result);
    }
    return record;
  }

  std::string rig_, plane_, left_, right_, pairs_, json_, ply_, overlay_;
  bool no_correction_ = false;
  double guard_band_mm_ = -1;  // < 0: none
  InspectionParams params_;
};

}  // namespace

std::unique_ptr<Command> MakeInspectCommand() { return std::make_unique<InspectCommand>(); }

}  // namespace flatscan
