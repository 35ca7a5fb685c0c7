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

}  // namespace
}  // namespace flatscan
