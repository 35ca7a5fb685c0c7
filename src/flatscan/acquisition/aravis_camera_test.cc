// The Aravis layer against Aravis's in-process fake camera (no hardware).
#include "flatscan/acquisition/aravis_camera.h"

#include <algorithm>
#include <vector>

#include <gtest/gtest.h>

#include "flatscan/util/error.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

// A backlight image: the top tenth saturated, the bottom twentieth dark, grey 100 between.
void Backlit(int width, int height, uint8_t* pixels, uint64_t /*frame_id*/) {
  for (int y = 0; y < height; ++y) {
    const uint8_t grey = y < height / 10 ? 255 : y >= height - height / 20 ? 0 : 100;
    std::fill(pixels + size_t(y) * size_t(width), pixels + size_t(y + 1) * size_t(width), grey);
  }
}

TEST(AravisCamera, ATestGrabMeasuresTheFramesTheCameraGives) {
  const auto camera = AravisCamera::OpenFake("LEFT", 320, 240, Backlit);
  EXPECT_EQ(camera->Name(), "Aravis Fake (LEFT)");
  const GrabStatistics s = camera->TestGrab(5, std::chrono::milliseconds(2000));
  EXPECT_EQ(s.frames, 5);
  EXPECT_EQ(s.incomplete, 0);
  EXPECT_EQ(s.width, 320);
  EXPECT_EQ(s.height, 240);
  EXPECT_EQ(s.pixel_format, "Mono8");
  EXPECT_DOUBLE_EQ(s.saturated_share, 24.0 / 240);
  EXPECT_DOUBLE_EQ(s.dark_share, 12.0 / 240);
  EXPECT_DOUBLE_EQ(s.mean_grey, (24 * 255.0 + 204 * 100.0) / 240);
  EXPECT_GT(s.frames_per_second, 0);
}

TEST(PixelFormat, TenTwelveAndSixteenBitsKeepTheirEightMostSignificantBits) {
  // Mono10: 4 raw levels a grey level; Mono12: 16; Mono16: 256. A stride wider than the row.
  const std::vector<uint16_t> raw = {0, 3, 4, 1023, 7, 9,  //
                                     16, 4095, 4096, 65535, 0, 0};
  const cv::Mat1b ten = ReduceToMono8(raw.data(), 4, 2, 6, 10);
  EXPECT_EQ(std::vector<uint8_t>(ten.begin(), ten.end()), (std::vector<uint8_t>{0, 0, 1, 255, 4, 255, 255, 255}));
  const cv::Mat1b twelve = ReduceToMono8(raw.data(), 4, 2, 6, 12);
  EXPECT_EQ(std::vector<uint8_t>(twelve.begin(), twelve.end()), (std::vector<uint8_t>{0, 0, 0, 63, 1, 255, 255, 255}));
  const cv::Mat1b sixteen = ReduceToMono8(raw.data(), 4, 2, 6, 16);
  EXPECT_EQ(std::vector<uint8_t>(sixteen.begin(), sixteen.end()), (std::vector<uint8_t>{0, 0, 0, 3, 0, 15, 16, 255}));
  EXPECT_EQ(ParsePixelFormat("Mono12", "--pixel-format"), PixelFormat::kMono12);
  EXPECT_EQ(PixelFormatName(PixelFormat::kMono10), "Mono10");
  EXPECT_EQ(testing::InputErrorOf([] { ParsePixelFormat("Mono12p", "--pixel-format"); }),
            "--pixel-format 'Mono12p': expected Mono8, Mono10, Mono12 or Mono16 (unpacked)");
}

TEST(AravisCamera, AFakeFrameAsLargeAsTheCompactRigs) {  // beyond the fake sensor's 2048 x 2048
  const auto camera = AravisCamera::OpenFake("RIGHT", 2592, 1944, Backlit);
  const GrabStatistics s = camera->TestGrab(2, std::chrono::milliseconds(2000));
  EXPECT_EQ(s.frames, 2);
  EXPECT_EQ(s.width, 2592);
  EXPECT_EQ(s.height, 1944);
  EXPECT_DOUBLE_EQ(s.saturated_share, 194.0 / 1944);
}

TEST(AravisCamera, ListsTheFakeCameraOnlyWhenAskedAndNamesOneItCannotFind) {
  // The fake interface only: GigE Vision discovery would broadcast on the machine's networks.
  const std::vector<CameraInfo> with_fake = ListCameras(CameraInterfaces::FakeOnly());
  const auto fake = std::find_if(with_fake.begin(), with_fake.end(), [](const CameraInfo& c) { return c.id == "Fake_1"; });
  ASSERT_NE(fake, with_fake.end());
  EXPECT_EQ(fake->protocol, "Fake");
  EXPECT_EQ(CameraInfoToJson(*fake).at("serial"), fake->serial);
  EXPECT_TRUE(ListCameras(CameraInterfaces{false, false, false}).empty());
  try {
    AravisCamera::Open("NO-SUCH-CAMERA", CameraInterfaces::FakeOnly());
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("camera 'NO-SUCH-CAMERA': not found among the "), std::string::npos)
        << e.what();
  }
}

TEST(AravisCamera, InterfacesAreParsedAndAnUnknownOneNamed) {
  const CameraInterfaces i = ParseCameraInterfaces("usb3,fake", "--interfaces");
  EXPECT_TRUE(!i.gige && i.usb3 && i.fake);
  EXPECT_EQ(testing::InputErrorOf([] { ParseCameraInterfaces("gige,usb", "--interfaces"); }),
            "--interfaces 'gige,usb': expected a comma-separated list of gige, usb3, fake");
}

TEST(GreyStatistics, FramesAreWeightedByTheirPixels) {
  GrabStatistics s;
  size_t pixels = 0;
  const std::vector<uint8_t> bright(100, 255), dark(300, 0);
  AddGreyStatistics(bright.data(), bright.size(), s, pixels);
  AddGreyStatistics(dark.data(), dark.size(), s, pixels);
  EXPECT_EQ(pixels, 400u);
  EXPECT_DOUBLE_EQ(s.saturated_share, 0.25);
  EXPECT_DOUBLE_EQ(s.dark_share, 0.75);
  EXPECT_DOUBLE_EQ(s.mean_grey, 63.75);
}

}  // namespace
}  // namespace flatscan
