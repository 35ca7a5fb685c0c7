#include "flatscan/io/file_storage_limits.h"

#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

namespace flatscan {
namespace {

// What OpenCV writes, and what people write by hand, passes.
TEST(FileStorageLimits, RigPlaneAndSceneLayoutsPass) {
  cv::FileStorage out(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  out << "image_width" << 640 << "M1" << cv::Mat::eye(3, 3, CV_64F) << "names" << std::vector<std::string>{"a", "b"};
  out << "nested" << "{" << "x" << 1 << "}";
  const std::string written = out.releaseAndGetString();
  EXPECT_EQ(FileStorageLimitExceeded(written), std::nullopt) << written;
  EXPECT_EQ(YamlLayoutProblem("# a scene\n---\ncamera:\n  width: 960   # px\n\n  height: 720\r\nboard: {poses: 3}\n"
                              "...\n# end\n\n"),
            std::nullopt);
  EXPECT_EQ(YamlLayoutProblem(""), std::nullopt);
  // Not YAML to OpenCV (no %YAML): its layout is XML's or JSON's business.
  EXPECT_EQ(FileStorageLimitExceeded(" L:1\n- \n-"), std::nullopt);
}

// Found by fuzz/plane_file_fuzz.cc: OpenCV's YAML parser never returned on these.
TEST(FileStorageLimits, LayoutsThatHangOpenCvsYamlParserAreRefused) {
  EXPECT_EQ(FileStorageLimitExceeded("%YAML:1.\n L:1\n- \n-"),
            "line 2 is indented, but the top-level keys start at the beginning of a line");
  EXPECT_EQ(FileStorageLimitExceeded("%YAML:1.0\nk: 1\n...\n-x\n"),
            "line 4: text after the end of the document ('...' on an earlier line)");
  EXPECT_EQ(FileStorageLimitExceeded("%YAML:1.0\nk: 1\n- x\n"),
            "line 3 starts with '-': the file must be one YAML map, its keys at the start of a line and their "
            "values indented");
  EXPECT_EQ(FileStorageLimitExceeded("%YAML:1.0\n----!!\n----!!\n"),
            "line 2 starts with '-': the file must be one YAML map, its keys at the start of a line and their "
            "values indented");
  EXPECT_EQ(FileStorageLimitExceeded("%YAML:1.0\n---\nk: 1\n---\nk: 2\n"),
            "line 4: a second document ('---'); the file must be one YAML map");
  EXPECT_EQ(FileStorageLimitExceeded("k: 1\n\tj: 2\n", /*yaml=*/true),
            "line 2 starts with a tab (YAML indents with spaces): the file must be one YAML map, its keys at the "
            "start of a line and their values indented");
  EXPECT_EQ(FileStorageLimitExceeded(std::string("k: 1\n\x01j: 2\n"), /*yaml=*/true),
            "line 2 starts with byte 0x01: the file must be one YAML map, its keys at the start of a line and their "
            "values indented");
}

TEST(FileStorageLimits, SizeAndNesting) {
  EXPECT_EQ(FileStorageLimitExceeded(std::string(kMaxFileStorageBytes + 1, ' ')),
            "1048577 bytes, more than the 1048576 a rig, plane or scene file may have");
  EXPECT_EQ(FileStorageLimitExceeded("%YAML:1.0\nk: [[[[[[[[[1]]]]]]]]]\n"), "brackets nested more than 8 deep");
  EXPECT_EQ(FileStorageLimitExceeded("%YAML:1.0\nk: [[[[[[[[1]]]]]]]]\n"), std::nullopt);
}

}  // namespace
}  // namespace flatscan
