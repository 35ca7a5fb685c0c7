#include "flatscan/io/atomic_output.h"

#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <optional>
#include <set>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "flatscan/util/error.h"

namespace flatscan {
namespace {
namespace fs = std::filesystem;

// Each test gets its own empty folder, removed afterwards.
class AtomicOutput : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           fmt::format("flatscan_atomic_{}_{}", static_cast<long>(::getpid()), info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::permissions(dir_, fs::perms::owner_all, fs::perm_options::add, ignored);
    fs::remove_all(dir_, ignored);
  }

  static std::string ReadText(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
  // Names of the entries of a folder (hidden ones included).
  static std::set<std::string> Entries(const fs::path& folder) {
    std::set<std::string> names;
    for (const auto& e : fs::directory_iterator(folder)) names.insert(e.path().filename().string());
    return names;
  }
  // The message of the InputError `f` throws, or nullopt.
  template <typename F>
  static std::optional<std::string> InputErrorOf(F&& f) {
    try {
      f();
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::nullopt;
  }

  fs::path dir_;
};

TEST_F(AtomicOutput, WritesAndReplacesTextFile) {
  const fs::path path = dir_ / "report.txt";
  WriteTextFileAtomically(path, "first\n");
  EXPECT_EQ(ReadText(path), "first\n");
  WriteTextFileAtomically(path, "second");
  EXPECT_EQ(ReadText(path), "second");
  EXPECT_EQ(Entries(dir_), std::set<std::string>{"report.txt"});
}

TEST_F(AtomicOutput, TemporaryIsHiddenInSameFolderAndKeepsExtension) {
  for (const std::string name : {"rig.yml", "scan.yml.gz", "noext"}) {
    const fs::path path = dir_ / name;
    fs::path seen;
    WriteFileAtomically(path, [&](const fs::path& tmp) {
      seen = tmp;
      std::ofstream(tmp) << "x";
    });
    EXPECT_EQ(seen.parent_path(), dir_) << name;
    EXPECT_TRUE(seen.filename().string().starts_with(".")) << seen;
    const std::string expected_end = name == "noext" ? "" : name.substr(name.find('.'));
    EXPECT_TRUE(seen.string().ends_with(expected_end)) << seen;
    EXPECT_NE(seen.filename(), path.filename());
    EXPECT_FALSE(fs::exists(seen));
    EXPECT_EQ(ReadText(path), "x");
  }
  EXPECT_EQ(Entries(dir_), (std::set<std::string>{"rig.yml", "scan.yml.gz", "noext"}));
}

TEST_F(AtomicOutput, FileStorageWritesTheFormatOfTheFinalName) {
  const fs::path path = dir_ / "values.yml";
  WriteFileAtomically(path, [](const fs::path& tmp) {
    cv::FileStorage out(tmp.string(), cv::FileStorage::WRITE);
    out << "answer" << 42;
  });
  EXPECT_TRUE(ReadText(path).starts_with("%YAML")) << ReadText(path);
  cv::FileStorage in(path.string(), cv::FileStorage::READ);
  EXPECT_EQ(static_cast<int>(in["answer"]), 42);
}

TEST_F(AtomicOutput, FailedWriteKeepsOldFileAndLeavesNoTemporary) {
  const fs::path path = dir_ / "result.json";
  WriteTextFileAtomically(path, "old content");
  EXPECT_THROW(WriteFileAtomically(path,
                                   [](const fs::path& tmp) {
                                     std::ofstream(tmp) << "half writ";
                                     throw std::runtime_error("disk on fire");
                                   }),
               std::runtime_error);
  EXPECT_EQ(ReadText(path), "old content");
  EXPECT_EQ(Entries(dir_), std::set<std::string>{"result.json"});
}

TEST_F(AtomicOutput, FailedFirstWriteLeavesNothing) {
  const fs::path path = dir_ / "image.png";
  EXPECT_THROW(WriteFileAtomically(path,
                                   [&](const fs::path& tmp) {
                                     std::ofstream(tmp) << "partial";
                                     ThrowInputError("cannot encode '{}'", path.string());
                                   }),
               InputError);
  EXPECT_TRUE(Entries(dir_).empty());
}

TEST_F(AtomicOutput, WriterThatWritesNothingIsInputError) {
  const fs::path path = dir_ / "image.png";
  EXPECT_EQ(InputErrorOf([&] { WriteFileAtomically(path, [](const fs::path&) {}); }),
            fmt::format("cannot write '{}': the writer produced no file", path.string()));
  EXPECT_TRUE(Entries(dir_).empty());
}

TEST_F(AtomicOutput, MissingFolderIsInputErrorNamingPath) {
  const fs::path path = dir_ / "missing" / "rig.yml";
  bool called = false;
  EXPECT_EQ(InputErrorOf([&] { WriteFileAtomically(path, [&](const fs::path&) { called = true; }); }),
            fmt::format("cannot write '{}': folder '{}' does not exist", path.string(),
                        (dir_ / "missing").string()));
  EXPECT_FALSE(called);
}

TEST_F(AtomicOutput, PathUnderRegularFileIsInputErrorNamingPath) {
  const fs::path file = dir_ / "plain.txt";
  WriteTextFileAtomically(file, "I am a file");
  const fs::path path = file / "out.txt";
  EXPECT_EQ(InputErrorOf([&] { WriteTextFileAtomically(path, "x"); }),
            fmt::format("cannot write '{}': '{}' is not a folder", path.string(), file.string()));
  EXPECT_EQ(ReadText(file), "I am a file");
}

TEST_F(AtomicOutput, PathThatIsAFolderIsInputError) {
  fs::create_directory(dir_ / "taken");
  const fs::path path = dir_ / "taken";
  EXPECT_EQ(InputErrorOf([&] { WriteTextFileAtomically(path, "x"); }),
            fmt::format("cannot write '{}': a folder of that name exists", path.string()));
}

TEST_F(AtomicOutput, ReadOnlyFolderIsInputErrorNamingPath) {
  if (::geteuid() == 0) GTEST_SKIP() << "root can write into read-only folders";
  const fs::path folder = dir_ / "readonly";
  fs::create_directory(folder);
  fs::permissions(folder, fs::perms::owner_read | fs::perms::owner_exec);
  const fs::path path = folder / "rig.yml";
  EXPECT_EQ(InputErrorOf([&] { WriteTextFileAtomically(path, "x"); }),
            fmt::format("cannot write '{}': Permission denied", path.string()));
  fs::permissions(folder, fs::perms::owner_all);
  EXPECT_TRUE(Entries(folder).empty());
}

TEST_F(AtomicOutput, StagedDirectoryRemovedWithoutCommit) {
  const fs::path final_dir = dir_ / "run";
  fs::path staging;
  {
    StagedDirectory staged(final_dir);
    staging = staged.path();
    EXPECT_EQ(staged.final_path(), final_dir);
    EXPECT_EQ(staging, fs::path(fmt::format("{}.partial-{}", final_dir.string(),
                                            static_cast<long>(::getpid()))));
    EXPECT_TRUE(fs::is_directory(staging));
    WriteTextFileAtomically(staging / "report.txt", "half a run");
    fs::create_directory(staging / "sub");
    WriteTextFileAtomically(staging / "sub" / "more.txt", "more");
  }
  EXPECT_FALSE(fs::exists(staging));
  EXPECT_FALSE(fs::exists(final_dir));
  EXPECT_TRUE(Entries(dir_).empty());
}

TEST_F(AtomicOutput, StagedDirectoryRemovedWhenExceptionUnwinds) {
  const fs::path final_dir = dir_ / "run";
  try {
    StagedDirectory staged(final_dir);
    WriteTextFileAtomically(staged.path() / "a.txt", "a");
    throw std::runtime_error("interrupted");
  } catch (const std::runtime_error&) {
  }
  EXPECT_TRUE(Entries(dir_).empty());
}

TEST_F(AtomicOutput, StagedDirectoryCommitCreatesParentsAndFinal) {
  const fs::path final_dir = dir_ / "a" / "b" / "run";
  {
    StagedDirectory staged(final_dir);
    EXPECT_TRUE(fs::is_directory(dir_ / "a" / "b"));
    EXPECT_FALSE(fs::exists(final_dir));
    WriteTextFileAtomically(staged.path() / "report.txt", "done");
    staged.Commit();
    EXPECT_EQ(staged.path(), final_dir);
  }
  EXPECT_EQ(ReadText(final_dir / "report.txt"), "done");
  EXPECT_EQ(Entries(dir_ / "a" / "b"), std::set<std::string>{"run"});
}

TEST_F(AtomicOutput, StagedDirectoryCommitReplacesAFolderItWrote) {
  const fs::path final_dir = dir_ / "run";
  {
    StagedDirectory first(final_dir);
    fs::create_directories(first.path() / "old_sub");
    WriteTextFileAtomically(first.path() / "report.txt", "old report");
    first.Commit();
  }
  {
    StagedDirectory staged(final_dir);
    WriteTextFileAtomically(staged.path() / "report.txt", "new report");
    EXPECT_EQ(ReadText(final_dir / "report.txt"), "old report");  // untouched until Commit
    staged.Commit();
  }
  EXPECT_EQ(Entries(final_dir), (std::set<std::string>{".flatscan-output", "report.txt"}));
  EXPECT_EQ(ReadText(final_dir / "report.txt"), "new report");
  EXPECT_EQ(Entries(dir_), std::set<std::string>{"run"});
}

// Before: `simulate -o` and `evaluate -o` deleted any folder (one held someone's thesis).
TEST_F(AtomicOutput, StagedDirectoryRefusesAFolderItDidNotWriteUnlessForced) {
  const fs::path final_dir = dir_ / "thesis";
  fs::create_directories(final_dir);
  WriteTextFileAtomically(final_dir / "chapter1.tex", "years of work");
  EXPECT_EQ(InputErrorOf([&] { StagedDirectory staged(final_dir); }),
            fmt::format("cannot replace '{}': the folder exists and flatscan did not write it (it has no "
                        ".flatscan-output); choose another output folder, or give --force to replace it",
                        final_dir.string()));
  EXPECT_EQ(ReadText(final_dir / "chapter1.tex"), "years of work");
  EXPECT_EQ(Entries(dir_), std::set<std::string>{"thesis"});  // no staging folder either
  {
    StagedDirectory staged(final_dir, /*replace_any=*/true);
    staged.Commit();
  }
  EXPECT_EQ(Entries(final_dir), std::set<std::string>{".flatscan-output"});
}

// A process killed outright leaves its staging folder; the next run removes it.
TEST_F(AtomicOutput, StagedDirectoryRemovesStalePartialsOfDeadProcesses) {
  const fs::path stale = dir_ / "run.partial-999999999";  // above the kernel's pid_max
  fs::create_directories(stale);
  WriteTextFileAtomically(stale / StagedDirectory::kOutputMarker, "");
  const fs::path foreign = dir_ / "run.partial-999999998";  // not ours: kept
  fs::create_directories(foreign);
  StagedDirectory staged(dir_ / "run");
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(foreign));
}

TEST_F(AtomicOutput, StagedDirectoriesOfSameFinalDoNotCollide) {
  const fs::path final_dir = dir_ / "run";
  StagedDirectory first(final_dir);
  StagedDirectory second(final_dir);
  EXPECT_NE(first.path(), second.path());
  EXPECT_TRUE(fs::is_directory(first.path()));
  EXPECT_TRUE(fs::is_directory(second.path()));
}

TEST_F(AtomicOutput, StagedDirectoryTrailingSlashNamesTheFolder) {
  StagedDirectory staged(fs::path(dir_.string() + "/run/"));
  EXPECT_EQ(staged.final_path(), dir_ / "run");
  staged.Commit();
  EXPECT_TRUE(fs::is_directory(dir_ / "run"));
}

TEST_F(AtomicOutput, StagedDirectoryUnderRegularFileIsInputErrorNamingPath) {
  const fs::path file = dir_ / "plain.txt";
  WriteTextFileAtomically(file, "I am a file");
  const fs::path final_dir = file / "run";
  EXPECT_EQ(InputErrorOf([&] { StagedDirectory staged(final_dir); }),
            fmt::format("cannot create folder '{}': '{}' is not a folder", final_dir.string(),
                        file.string()));
  const fs::path deeper = file / "x" / "run";
  const std::optional<std::string> message = InputErrorOf([&] { StagedDirectory staged(deeper); });
  ASSERT_TRUE(message.has_value());
  EXPECT_TRUE(message->starts_with(fmt::format("cannot create folder '{}': cannot create '{}': ",
                                               deeper.string(), (file / "x").string())))
      << *message;
  EXPECT_EQ(Entries(dir_), std::set<std::string>{"plain.txt"});
}

// Before: `evaluate -o <existing file>` failed only after the whole run.
TEST_F(AtomicOutput, StagedDirectoryRefusesToReplaceAFileBeforeAnyWork) {
  const fs::path final_dir = dir_ / "run";
  WriteTextFileAtomically(final_dir, "a file where the folder should go");
  EXPECT_EQ(InputErrorOf([&] { StagedDirectory staged(final_dir, /*replace_any=*/true); }),
            fmt::format("cannot replace '{}': it exists and is not a folder", final_dir.string()));
  EXPECT_EQ(Entries(dir_), std::set<std::string>{"run"});
  EXPECT_EQ(ReadText(final_dir), "a file where the folder should go");
}

}  // namespace
}  // namespace flatscan
