// End-to-end tests of `flatscan edges` and `flatscan evaluate-edges`: outputs, exit
// codes and messages for bad input (issue 3 "Bad input").
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "flatscan/evaluation/edge_accuracy.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

using testing::RunFlatscan;
using testing::ScratchDir;

const char kHeader[] = "x,y,nx,ny,h,contour\n";

// A dark disc of radius 20 px centred at (40.3, 39.6) on an 80 x 80 bright field.
cv::Mat1b DiscImage() {
  EdgeImageSpec spec;
  spec.blur_sigma = 1.0;
  spec.noise_sigma = 2.0;
  return RenderEdgeImage(TrueCurve::Circle({40.3, 39.6}, 20.0), 80, 80, spec);
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

TEST(EdgesCommand, WritesTheCsvAndOverlayOfARenderedDisc) {
  ScratchDir dir("edges-disc");
  const auto image = dir.path() / "disc.png";
  ASSERT_TRUE(cv::imwrite(image.string(), DiscImage()));
  const auto csv = dir.path() / "disc.csv", overlay = dir.path() / "overlay.png";
  const auto r = RunFlatscan("edges " + image.string() + " --csv " + csv.string() + " --overlay " + overlay.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("disc.png: "), std::string::npos) << r.out;
  const std::vector<std::string> lines = Lines(testing::ReadFileBytes(csv));
  ASSERT_GT(lines.size(), 50u);
  EXPECT_EQ(lines[0] + "\n", kHeader);
  double radius_sum = 0.0;
  for (size_t i = 1; i < lines.size(); ++i) {
    double x, y, nx, ny, h;
    int contour;
    ASSERT_EQ(std::sscanf(lines[i].c_str(), "%lf,%lf,%lf,%lf,%lf,%d", &x, &y, &nx, &ny, &h, &contour), 6) << lines[i];
    const double radius = std::hypot(x - 40.3, y - 39.6);
    EXPECT_NEAR(radius, 20.0, 0.5) << lines[i];
    EXPECT_NEAR(std::hypot(nx, ny), 1.0, 1e-3) << lines[i];
    EXPECT_GT((nx * (x - 40.3) + ny * (y - 39.6)) / radius, 0.9) << "normal points dark -> bright: " << lines[i];
    radius_sum += radius;
  }
  EXPECT_NEAR(radius_sum / (lines.size() - 1), 20.0, 0.1);
  const cv::Mat drawn = cv::imread(overlay.string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(drawn.empty());
  EXPECT_EQ(drawn.channels(), 3);
  EXPECT_EQ(drawn.cols % 80, 0);
  EXPECT_GE(drawn.cols, 160);
  for (const auto& entry : std::filesystem::directory_iterator(dir.path()))
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos) << entry.path();
}

TEST(EdgesCommand, BadInputExitsTwoWithAClearMessageAndNoCsv) {
  ScratchDir dir("edges-bad");
  const auto csv = dir.path() / "out.csv";
  auto run = [&](const std::filesystem::path& image, const std::string& extra = "") {
    return RunFlatscan("edges " + image.string() + " --csv " + csv.string() + extra);
  };
  auto r = run(dir.path() / "missing.png");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find((dir.path() / "missing.png").string() + ": no such file"), std::string::npos) << r.err;

  const std::string unreadable = ": cannot read image (expected an 8-bit grey PNG, JPEG, BMP, TIFF or PGM file)";
  std::ofstream(dir.path() / "empty.png").close();
  r = run(dir.path() / "empty.png");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find((dir.path() / "empty.png").string() + unreadable), std::string::npos) << r.err;

  std::ofstream(dir.path() / "garbage.png") << "this is not a PNG file at all";
  r = run(dir.path() / "garbage.png");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find((dir.path() / "garbage.png").string() + unreadable), std::string::npos) << r.err;

  const auto tiny = dir.path() / "tiny.png";
  ASSERT_TRUE(cv::imwrite(tiny.string(), cv::Mat1b(5, 6, uchar(100))));
  r = run(tiny);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(tiny.string() + ": image is 6 x 5 pixels, smaller than the 7 x 7 window of the edge operator"),
            std::string::npos)
      << r.err;

  const auto disc = dir.path() / "disc.png";
  ASSERT_TRUE(cv::imwrite(disc.string(), DiscImage()));
  r = run(disc, " --overlay " + (dir.path() / "overlay.xyz").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("overlay.xyz: unknown image format for --overlay (use .png, .jpg, .bmp or .tif)"),
            std::string::npos)
      << r.err;
  r = run(disc, " --method sobel");
  EXPECT_EQ(r.exit_code, 2);
  r = run(disc, " --blur -1");
  EXPECT_EQ(r.exit_code, 2);
  r = RunFlatscan("edges " + disc.string());  // --csv is required
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--csv is required"), std::string::npos) << r.err;
  r = run(disc, "");
  EXPECT_EQ(r.exit_code, 0) << r.err;  // the same command with good input works
  std::filesystem::remove(csv);
  r = RunFlatscan("edges " + disc.string() + " --csv " + (dir.path() / "no-folder" / "out.csv").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(fmt::format("--csv '{}': the folder '{}' does not exist", (dir.path() / "no-folder/out.csv").string(),
                                   (dir.path() / "no-folder").string())),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(std::filesystem::exists(csv));
  // Before: the CSV replaced the input image (exit 0).
  const std::string image_bytes = testing::ReadFileBytes(disc);
  r = RunFlatscan("edges " + disc.string() + " --csv " + disc.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(fmt::format("--csv '{}': is the input of image; choose another output name", disc.string())),
            std::string::npos)
      << r.err;
  EXPECT_EQ(testing::ReadFileBytes(disc), image_bytes);
  // "-": the CSV on standard output, the summary on stderr.
  r = RunFlatscan("edges " + disc.string() + " --csv -");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.rfind("x,y,nx,ny,h,contour\n", 0), 0u) << r.out.substr(0, 200);
}

TEST(EdgesCommand, ConvertsSixteenBitAndColourImagesWithAWarning) {
  ScratchDir dir("edges-convert");
  const cv::Mat1b disc = DiscImage();
  const auto csv = dir.path() / "out.csv";

  cv::Mat deep;
  disc.convertTo(deep, CV_16U, 256.0);  // a 16-bit camera image of the same scene
  const auto deep_path = dir.path() / "deep.png";
  ASSERT_TRUE(cv::imwrite(deep_path.string(), deep));
  double max_value = 0.0;
  cv::minMaxLoc(deep, nullptr, &max_value);
  auto r = RunFlatscan("edges " + deep_path.string() + " --csv " + csv.string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find(deep_path.string() + ": 16-bit image converted to 8 bits by scaling its maximum " +
                       std::to_string(static_cast<int>(max_value)) + " to 255"),
            std::string::npos)
      << r.err;
  EXPECT_GT(Lines(testing::ReadFileBytes(csv)).size(), 50u);

  cv::Mat colour;
  cv::Mat channels[3] = {disc, disc, disc};
  cv::merge(channels, 3, colour);
  const auto colour_path = dir.path() / "colour.png";
  ASSERT_TRUE(cv::imwrite(colour_path.string(), colour));
  r = RunFlatscan("edges " + colour_path.string() + " --csv " + csv.string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find(colour_path.string() + ": colour image converted to grey"), std::string::npos) << r.err;
  EXPECT_GT(Lines(testing::ReadFileBytes(csv)).size(), 50u);
}

TEST(EdgesCommand, AnImageWithoutEdgesGivesAHeaderOnlyCsvAndAWarning) {
  ScratchDir dir("edges-flat");
  const auto image = dir.path() / "flat.png", csv = dir.path() / "flat.csv";
  ASSERT_TRUE(cv::imwrite(image.string(), cv::Mat1b(64, 64, uchar(200))));
  for (const std::string extra : {"", " --whole-image", " --method canny", " --method zernike"}) {
    const auto r = RunFlatscan("edges " + image.string() + " --csv " + csv.string() + extra);
    EXPECT_EQ(r.exit_code, 0) << extra << r.err;
    EXPECT_NE(r.err.find(image.string() + ": no edge found; the CSV has only its header"), std::string::npos)
        << extra << r.err;
    EXPECT_EQ(testing::ReadFileBytes(csv), kHeader) << extra;
  }
}

TEST(EdgesCommand, HelpOfBothCommands) {
  for (const std::string sub : {"edges", "evaluate-edges"}) {
    const auto r = RunFlatscan(sub + " --help");
    EXPECT_EQ(r.exit_code, 0) << sub;
    EXPECT_NE(r.out.find("Usage"), std::string::npos) << sub;
  }
}

}  // namespace
}  // namespace flatscan
