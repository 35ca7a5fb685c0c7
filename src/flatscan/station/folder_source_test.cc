// The folder source on a real folder with real inotify events.
#include "flatscan/station/folder_source.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {
namespace fs = std::filesystem;
using std::chrono::milliseconds;

void WriteFile(const fs::path& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

// Writes under a temporary name, then renames into place (the safe way to deliver).
void Deliver(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.parent_path() / fmt::format(".{}.tmp", path.filename().string());
  WriteFile(tmp, text);
  fs::rename(tmp, path);
}

FolderSourceOptions Fast() {
  FolderSourceOptions o;
  o.half_pair_timeout = milliseconds(300);
  o.settle = milliseconds(0);
  return o;
}

// The next pair within `timeout`, or nullopt.
std::optional<SourcePair> NextWithin(PairSource& source, milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline)
    if (auto pair = source.Next(milliseconds(50))) return pair;
  return std::nullopt;
}

TEST(FolderSource, TakesPairsPresentAtStartThenPairsAsTheyComplete) {
  testing::ScratchDir dir("folder-source");
  const fs::path d = dir.path();
  WriteFile(d / "a_left.png", "L");
  WriteFile(d / "a_right.png", "R");
  WriteFile(d / "notes.txt", "not a pair");
  WriteFile(d / ".b_left.png", "a temporary");
  auto source = MakeFolderSource(d, Fast());
  auto pair = NextWithin(*source, milliseconds(2000));
  ASSERT_TRUE(pair);
  EXPECT_EQ(pair->source_id, "a");
  EXPECT_EQ(pair->left, d / "a_left.png");
  EXPECT_FALSE(pair->not_measurable);
  EXPECT_FALSE(source->Next(milliseconds(100)));

  // A file written in place counts when it is closed.
  Deliver(d / "b_right.png", "R");
  std::ofstream open_file(d / "b_left.png", std::ios::binary);
  open_file << "half of it";
  open_file.flush();
  EXPECT_FALSE(source->Next(milliseconds(150)));
  open_file << " and the rest";
  open_file.close();
  pair = NextWithin(*source, milliseconds(2000));
  ASSERT_TRUE(pair);
  EXPECT_EQ(pair->source_id, "b");

  // Done: both files move to done/.
  source->Done(*pair);
  EXPECT_FALSE(fs::exists(d / "b_left.png"));
  EXPECT_EQ(testing::ReadFileBytes(d / "done/b_left.png"), "half of it and the rest");
  EXPECT_EQ(testing::ReadFileBytes(d / "done/b_right.png"), "R");
}

TEST(FolderSource, AHalfPairIsHandedOutAfterItsTimeout) {
  testing::ScratchDir dir("folder-half");
  const fs::path d = dir.path();
  auto source = MakeFolderSource(d, Fast());
  Deliver(d / "c_left.png", "L");
  const auto start = std::chrono::steady_clock::now();
  const auto pair = NextWithin(*source, milliseconds(3000));
  ASSERT_TRUE(pair);
  EXPECT_GE(std::chrono::steady_clock::now() - start, milliseconds(250));
  ASSERT_TRUE(pair->not_measurable);
  EXPECT_EQ(*pair->not_measurable, "half pair: the right image " + (d / "c_right.png").string() +
                                       " did not arrive within 0.3 s of the left image " + (d / "c_left.png").string());
  source->Done(*pair);
  EXPECT_TRUE(fs::exists(d / "done/c_left.png"));
  EXPECT_FALSE(fs::exists(d / "c_left.png"));
}

TEST(FolderSource, DoneKeepsTheNewestPairs) {
  testing::ScratchDir dir("folder-done");
  const fs::path d = dir.path();
  FolderSourceOptions options = Fast();
  options.keep_done = 2;
  auto source = MakeFolderSource(d, options);
  for (const std::string id : {"p1", "p2", "p3"}) {
    Deliver(d / (id + "_left.png"), "L");
    Deliver(d / (id + "_right.png"), "R");
    const auto pair = NextWithin(*source, milliseconds(2000));
    ASSERT_TRUE(pair);
    EXPECT_EQ(pair->source_id, id);
    source->Done(*pair);
  }
  EXPECT_FALSE(fs::exists(d / "done/p1_left.png"));
  EXPECT_FALSE(fs::exists(d / "done/p1_right.png"));
  EXPECT_TRUE(fs::exists(d / "done/p2_left.png"));
  EXPECT_TRUE(fs::exists(d / "done/p3_right.png"));
}

// kill -9 between moving the right and the left image: the restart finishes the move
// instead of taking the left image for a new half pair.
TEST(FolderSource, ARestartFinishesAnInterruptedMove) {
  testing::ScratchDir dir("folder-restart");
  const fs::path d = dir.path();
  fs::create_directories(d / "done");
  WriteFile(d / "done/x_right.png", "R");
  WriteFile(d / "x_left.png", "L");
  ASSERT_EQ(::link((d / "x_left.png").c_str(), (d / "done/x_left.png").c_str()), 0);
  auto source = MakeFolderSource(d, Fast());
  EXPECT_FALSE(fs::exists(d / "x_left.png"));
  EXPECT_EQ(testing::ReadFileBytes(d / "done/x_left.png"), "L");
  EXPECT_FALSE(NextWithin(*source, milliseconds(600)));  // no half pair after its timeout either
}

// kill -9 after the left image was linked into done/ and before the right one was: the
// record was committed, so the restart moves both instead of making the right image a
// half pair (a second record).
TEST(FolderSource, ARestartFinishesAMoveInterruptedBetweenTheTwoLinks) {
  testing::ScratchDir dir("folder-restart-2");
  const fs::path d = dir.path();
  fs::create_directories(d / "done");
  WriteFile(d / "y_left.png", "L");
  WriteFile(d / "y_right.png", "R");
  ASSERT_EQ(::link((d / "y_left.png").c_str(), (d / "done/y_left.png").c_str()), 0);
  auto source = MakeFolderSource(d, Fast());
  EXPECT_FALSE(fs::exists(d / "y_left.png"));
  EXPECT_FALSE(fs::exists(d / "y_right.png"));
  EXPECT_EQ(testing::ReadFileBytes(d / "done/y_right.png"), "R");
  EXPECT_FALSE(NextWithin(*source, milliseconds(600)));
}

// The partner of a half pair arrives while the half pair is being recorded: it is not
// moved away with it, and becomes a half pair of its own.
TEST(FolderSource, AFileThatArrivesForAPairThatIsOutWaitsForIt) {
  testing::ScratchDir dir("folder-late");
  const fs::path d = dir.path();
  auto source = MakeFolderSource(d, Fast());
  Deliver(d / "z_left.png", "L");
  const auto half = NextWithin(*source, milliseconds(3000));
  ASSERT_TRUE(half && half->not_measurable);
  Deliver(d / "z_right.png", "late R");
  EXPECT_FALSE(source->Next(milliseconds(100)));  // it waits for the half pair
  source->Done(*half);
  EXPECT_TRUE(fs::exists(d / "done/z_left.png"));
  EXPECT_EQ(testing::ReadFileBytes(d / "z_right.png"), "late R");  // not moved with the half pair
  const auto late = NextWithin(*source, milliseconds(3000));
  ASSERT_TRUE(late && late->not_measurable);
  EXPECT_NE(late->not_measurable->find("the left image " + (d / "z_left.png").string() + " did not arrive"),
            std::string::npos);
  source->Done(*late);
  EXPECT_EQ(testing::ReadFileBytes(d / "done/z_right.png"), "late R");
}

TEST(FolderSource, RefusesAFolderThatIsNotThere) {
  EXPECT_EQ(testing::InputErrorOf([] { MakeFolderSource("/nonexistent/incoming"); }),
            "--source folder:/nonexistent/incoming: no such folder");
}

}  // namespace
}  // namespace flatscan
