#include "flatscan/io/output_files.h"

#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <set>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "flatscan/util/error.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {
namespace fs = std::filesystem;

class OutputFilesTest : public ::testing::Test {
 protected:
  OutputFilesTest() : dir_("output-files") {
    std::ofstream(Path("input.png")) << "image";
    std::ofstream(Path("old.json")) << "old";
  }
  std::string Path(const std::string& name) const { return (dir_.path() / name).string(); }
  // The names in the folder (temporaries included).
  std::set<std::string> Names() const {
    std::set<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_.path())) names.insert(e.path().filename().string());
    return names;
  }

  testing::ScratchDir dir_;
};

TEST_F(OutputFilesTest, RefusesAnOutputThatIsAnInputAlsoThroughALink) {
  OutputFiles out({{"--left", Path("input.png")}});
  EXPECT_EQ(testing::InputErrorOf([&] { out.Declare("--json", Path("input.png")); }),
            fmt::format("--json '{}': is the input of --left; choose another output name", Path("input.png")));
  // The same file under another name: a hard link, and a path through "..".
  fs::create_hard_link(Path("input.png"), Path("hard.png"));
  EXPECT_EQ(testing::InputErrorOf([&] { out.Declare("--ply", Path("hard.png")); }),
            fmt::format("--ply '{}': is the input of --left; choose another output name", Path("hard.png")));
  fs::create_directory(Path("sub"));
  const std::string dotted = Path("sub/../input.png");
  EXPECT_EQ(testing::InputErrorOf([&] { out.Declare("--csv", dotted); }),
            fmt::format("--csv '{}': is the input of --left; choose another output name", dotted));
  EXPECT_EQ(testing::ReadFileBytes(Path("input.png")), "image");
}

TEST_F(OutputFilesTest, RefusesWhatIsNotARegularFile) {
  OutputFiles out({});
  fs::create_symlink(Path("old.json"), Path("link.json"));
  ASSERT_EQ(::mkfifo(Path("fifo").c_str(), 0600), 0);
  EXPECT_EQ(testing::InputErrorOf([&] { out.Declare("--json", Path("link.json")); }),
            fmt::format("--json '{}': is a symbolic link; an output must be a regular file or a new name "
                        "(flatscan replaces only regular files)",
                        Path("link.json")));
  EXPECT_EQ(testing::InputErrorOf([&] { out.Declare("--json", Path("fifo")); }).rfind(
                fmt::format("--json '{}': is a FIFO;", Path("fifo")), 0),
            0u);
  EXPECT_EQ(testing::InputErrorOf([&] { out.Declare("--json", "/dev/null"); }).rfind(
                "--json '/dev/null': is a character device;", 0),
            0u);
  EXPECT_EQ(testing::InputErrorOf([&] { out.Declare("--json", dir_.path()); }).rfind(
                fmt::format("--json '{}': is a folder;", dir_.path().string()), 0),
            0u);
  EXPECT_EQ(testing::InputErrorOf([&] { out.Declare("--json", Path("none/x.json")); }),
            fmt::format("--json '{}': the folder '{}' does not exist", Path("none/x.json"), Path("none")));
  EXPECT_EQ(testing::InputErrorOf([&] { out.Declare("--json", "-"); }),
            "--json: '-' (standard output) is not possible for this output; give a file name");
}

TEST_F(OutputFilesTest, RefusesTwoOutputsOfOneName) {
  OutputFiles out({});
  out.Declare("--json", Path("a.json"));
  EXPECT_EQ(testing::InputErrorOf([&] { out.Declare("--ply", Path("a.json")); }),
            fmt::format("--ply '{}': is also the output of --json; give each output its own name", Path("a.json")));
}

TEST_F(OutputFilesTest, NothingIsReplacedBeforeCommitAndAllAfter) {
  {
    OutputFiles out({});
    out.Declare("--json", Path("old.json"));
    out.Declare("--csv", Path("new.csv"));
    out.StageText("--json", "new");
    EXPECT_EQ(testing::ReadFileBytes(Path("old.json")), "old");
    // The work fails after the first output was staged: no output changes, no temporary stays.
  }
  EXPECT_EQ(Names(), (std::set<std::string>{"input.png", "old.json"}));
  EXPECT_EQ(testing::ReadFileBytes(Path("old.json")), "old");

  OutputFiles out({});
  out.Declare("--json", Path("old.json"));
  out.Declare("--csv", Path("new.csv"));
  out.Declare("--overlay", Path("overlays/sub/left.png"), OutputFiles::kCreateFolder);
  out.StageText("--json", "new");
  out.StageText("--csv", "a,b\n");
  out.StageText("--overlay", "png");
  out.Commit();
  EXPECT_EQ(testing::ReadFileBytes(Path("old.json")), "new");
  EXPECT_EQ(testing::ReadFileBytes(Path("new.csv")), "a,b\n");
  EXPECT_EQ(testing::ReadFileBytes(Path("overlays/sub/left.png")), "png");
  EXPECT_EQ(Names(), (std::set<std::string>{"input.png", "old.json", "new.csv", "overlays"}));
}

TEST_F(OutputFilesTest, DashIsStandardOutput) {
  OutputFiles out({});
  out.Declare("--json", "-", OutputFiles::kStdoutAllowed);
  out.StageText("--json", "{\"a\": 1}\n");
  ::testing::internal::CaptureStdout();
  out.Commit();
  EXPECT_EQ(::testing::internal::GetCapturedStdout(), "{\"a\": 1}\n");
}

TEST(SafeFileName, IdsStayInsideTheirFolder) {
  EXPECT_EQ(SafeFileName("part_007"), "part_007");
  EXPECT_EQ(SafeFileName("../../escape"), "_._.._escape");
  EXPECT_EQ(SafeFileName("/etc/passwd"), "_etc_passwd");
  EXPECT_EQ(SafeFileName(".hidden"), "_hidden");
  EXPECT_EQ(SafeFileName(""), "_");
  EXPECT_EQ(SafeFileName("a b\tc\xc3\xa9"), "a_b_c__");
  EXPECT_EQ(SafeFileName(std::string(300, 'x')).size(), 100u);
  std::set<std::string> taken;
  EXPECT_EQ(UniqueFileName("a", &taken), "a");
  EXPECT_EQ(UniqueFileName("a", &taken), "a-2");
  EXPECT_EQ(UniqueFileName("a", &taken), "a-3");
}

}  // namespace
}  // namespace flatscan
