#include "flatscan/station/image_archive.h"

#include <fstream>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {
namespace fs = std::filesystem;

// A record of the given kind for pair `id`, whose two images of `bytes` bytes exist.
std::pair<StationRecord, SourcePair> Pair(const fs::path& dir, const std::string& id, const std::string& kind,
                                          size_t bytes = 1000) {
  const SourcePair pair = FilePair(id, dir / (id + "_left.png"), dir / (id + "_right.png"));
  std::ofstream(pair.left) << std::string(bytes, 'L');
  std::ofstream(pair.right) << std::string(bytes, 'R');
  StationRecord r;
  r.record_id = NewRecordId();
  r.source_id = id;
  InspectionResult result;
  result.values = {kind == "pass" ? 0.05 : 0.2, 0, 0};
  r.inspection = kind == "not_measured" ? NotMeasuredRecord("no part", InspectionParams{}, {0.1, 0}, {})
                                        : MeasuredRecord(result, InspectionParams{}, {0.1, 0}, {});
  return {r, pair};
}

TEST(ImageArchive, KeepsFailsNotMeasuredAndOnePassInN) {
  testing::ScratchDir dir("archive");
  ImageArchive archive(dir.path() / "archive", 100, 90);
  ArchivePolicy policy;
  policy.keep_pass_every = 3;
  int kept_passes = 0;
  for (int i = 0; i < 7; ++i) {
    const auto [record, pair] = Pair(dir.path(), fmt::format("p{}", i), "pass");
    kept_passes += !archive.Keep(record, pair, policy).left.empty();
  }
  EXPECT_EQ(kept_passes, 3);  // the 1st, 4th and 7th
  const auto [fail, fail_pair] = Pair(dir.path(), "bad one:7", "fail");
  const ArchivedPair kept = archive.Keep(fail, fail_pair, policy);
  ASSERT_FALSE(kept.left.empty());
  EXPECT_EQ(fs::path(kept.left).parent_path().parent_path().filename(), "fail");
  EXPECT_EQ(fs::path(kept.left).filename(), "bad_one_7_" + fail.record_id.substr(0, 8) + "_left.png");
  EXPECT_EQ(testing::ReadFileBytes(kept.right), std::string(1000, 'R'));
  EXPECT_EQ(kept.thumbnail, "");  // none given
  // With the part's thumbnail: beside the images, and one pair with them.
  const auto [nm, nm_pair] = Pair(dir.path(), "n", "not_measured");
  const ArchivedPair with_thumbnail = archive.Keep(nm, nm_pair, policy, "JPEG bytes");
  EXPECT_EQ(fs::path(with_thumbnail.thumbnail).filename(), "n_" + nm.record_id.substr(0, 8) + "_thumb.jpg");
  EXPECT_EQ(testing::ReadFileBytes(with_thumbnail.thumbnail), "JPEG bytes");
  EXPECT_EQ(archive.pairs(), 5u);
  EXPECT_EQ(archive.bytes(), 5 * 2 * 1000 + 10);
  const ImageArchive again(dir.path() / "archive", 100, 90);  // indexed again at start-up
  EXPECT_EQ(again.pairs(), 5u);
  EXPECT_EQ(again.bytes(), 5 * 2 * 1000 + 10);
}

TEST(ImageArchive, TheQuotaEvictsTheOldestPassesAndNeverARecentFail) {
  testing::ScratchDir dir("archive-quota");
  // 10 kB quota, pairs of 2 x 2000 bytes: room for two pairs.
  ImageArchive archive(dir.path() / "a", 10.0 / 1024, 90);
  ArchivePolicy every;
  every.keep_pass_every = 1;
  std::vector<ArchivedPair> passes;
  for (int i = 0; i < 2; ++i) {
    const auto [r, p] = Pair(dir.path(), fmt::format("pass{}", i), "pass", 2000);
    passes.push_back(archive.Keep(r, p, every));
  }
  const auto [f1, p1] = Pair(dir.path(), "fail1", "fail", 2000);
  const ArchivedPair fail1 = archive.Keep(f1, p1, every);
  EXPECT_FALSE(fs::exists(passes[0].left));  // the oldest pass went first
  EXPECT_TRUE(fs::exists(passes[1].left));
  const auto [f2, p2] = Pair(dir.path(), "fail2", "fail", 2000);
  const ArchivedPair fail2 = archive.Keep(f2, p2, every);
  EXPECT_FALSE(fs::exists(passes[1].left));
  EXPECT_TRUE(fs::exists(fail1.left));
  const auto [f3, p3] = Pair(dir.path(), "fail3", "fail", 2000);
  archive.Keep(f3, p3, every);  // over quota: fails within retention are all kept
  EXPECT_TRUE(fs::exists(fail1.left));
  EXPECT_TRUE(fs::exists(fail2.left));
  EXPECT_EQ(archive.pairs(), 3u);
  EXPECT_GT(archive.bytes(), 10 * 1024);

  ImageArchive no_retention(dir.path() / "a", 10.0 / 1024, 0);  // fails older than 0 days may go
  const auto [f4, p4] = Pair(dir.path(), "fail4", "fail", 2000);
  no_retention.Keep(f4, p4, every);
  EXPECT_FALSE(fs::exists(fail1.left));
  EXPECT_LE(no_retention.bytes(), 10 * 1024);
}

}  // namespace
}  // namespace flatscan
