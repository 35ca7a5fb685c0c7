// flatscan cameras against Aravis's in-process fake camera.
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

// --interfaces fake: GigE Vision discovery would broadcast on the machine's networks.
TEST(CamerasCommand, ListsAndTestsTheFakeCamera) {
  const auto list = testing::RunFlatscan("cameras --interfaces fake --json", 60);
  ASSERT_EQ(list.exit_code, 0) << list.err;
  const nlohmann::json cameras = nlohmann::json::parse(list.out);
  ASSERT_TRUE(cameras.is_array());
  bool found = false;
  for (const auto& c : cameras) {
    for (const char* key : {"id", "serial", "model", "protocol", "address", "vendor"}) EXPECT_TRUE(c.contains(key)) << key;
    found = found || (c.at("id") == "Fake_1" && c.at("protocol") == "Fake");
  }
  EXPECT_TRUE(found) << list.out;

  const auto test = testing::RunFlatscan("cameras --interfaces fake --test Fake_1 --frames 3", 60);
  ASSERT_EQ(test.exit_code, 0) << test.err;
  EXPECT_NE(test.out.find("frames: 3 complete, 0 incomplete, 0 timed out"), std::string::npos) << test.out;
  EXPECT_NE(test.out.find(", Mono8\n"), std::string::npos) << test.out;

  const auto missing = testing::RunFlatscan("cameras --interfaces fake --test NO-SUCH-CAMERA", 60);
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("camera 'NO-SUCH-CAMERA': not found among the 1 GenICam camera(s) found"),
            std::string::npos)
      << missing.err;
  const auto bad = testing::RunFlatscan("cameras --interfaces gige,firewire", 60);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--interfaces 'gige,firewire': expected a comma-separated list of gige, usb3, fake"),
            std::string::npos)
      << bad.err;
}

// The GigE Vision protocol itself over loopback: Aravis's fake GigE camera
// (arv-fake-gv-camera-0.8, aravis-tools) listening on 127.0.0.1, opened by its address
// (no discovery broadcast), a test grab of real GVSP packets. GVCP's port is 3956 by the
// standard (the fake camera has no other): this is the only test that uses it.
TEST(CamerasCommand, TestsAGigEVisionCameraByItsAddressOverLoopback) {
  testing::ScratchDir dir("gige_fake");
  testing::BackgroundProcess camera("arv-fake-gv-camera-0.8", {"-i", "127.0.0.1", "-s", "GV-TEST-1"},
                                    dir.path() / "camera.log");
  ASSERT_TRUE(camera.started());
  testing::CommandResult grab;
  // The camera takes a moment to listen: a few tries.
  ASSERT_TRUE(testing::WaitFor(
      [&] {
        grab = testing::RunFlatscan("cameras --interfaces gige --test 127.0.0.1 --frames 5", 30);
        return grab.exit_code == 0;
      },
      20))
      << grab.err;
  EXPECT_NE(grab.out.find("camera Aravis Fake (GV-TEST-1, 127.0.0.1)"), std::string::npos) << grab.out;
  EXPECT_NE(grab.out.find("frames: 5 complete, 0 incomplete, 0 timed out"), std::string::npos) << grab.out;
  EXPECT_NE(grab.out.find("size: 512 x 512, Mono8"), std::string::npos) << grab.out;
  const auto absent = testing::RunFlatscan("cameras --interfaces gige --test 127.0.0.9 --frames 1", 30);
  EXPECT_EQ(absent.exit_code, 2);
  EXPECT_NE(absent.err.find("camera '127.0.0.9': cannot open the GigE Vision camera at this address: "),
            std::string::npos)
      << absent.err;
}

}  // namespace
}  // namespace flatscan
