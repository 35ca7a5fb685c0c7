#pragma once
// The files one command writes: declared (and checked) before any work, committed
// together after it, so that a command never replaces a file it did not create and
// never leaves some outputs of a failed run behind.
//
//   OutputFiles out({{"--rig", rig_path}, {"--left", left_path}});  // the inputs
//   out.Declare("--json", json_path, OutputFiles::kStdoutAllowed);   // checked here
//   ... the work ...
//   out.StageText("--json", text);                                   // to a temporary
//   out.Stage("-o", [&](const fs::path& p) { WriteRigFile(p, rig); });
//   out.Commit();                                                    // all renamed
//
// Declare refuses, with an InputError naming the option and the path:
//  - an output that is one of the inputs or another output (the same file, also through
//    hard or symbolic links: compared as resolved files);
//  - a path that exists and is not a regular file (a folder, a FIFO, a device, a socket)
//    or that is a symbolic link (writing through it would replace what it points to);
//  - a path whose folder does not exist (unless declared with kCreateFolder) or cannot
//    be written.
// "-" means standard output for outputs declared kStdoutAllowed: their text is printed
// at Commit(). Until Commit() nothing is renamed into place; an OutputFiles destroyed
// before Commit() (an exception during the work) removes its temporaries.
#include <filesystem>
#include <functional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace flatscan {

class OutputFiles {
 public:
  using Named = std::pair<std::string, std::filesystem::path>;  // option, path
  enum Flags { kNone = 0, kStdoutAllowed = 1, kCreateFolder = 2 };

  explicit OutputFiles(std::vector<Named> inputs);
  ~OutputFiles();
  OutputFiles(const OutputFiles&) = delete;
  OutputFiles& operator=(const OutputFiles&) = delete;

  // Checks `path` as described above and reserves it for `option`. An empty path is an
  // optional output that was not asked for: staging it does nothing.
  void Declare(const std::string& option, const std::filesystem::path& path, int flags = kNone);
  bool Declared(const std::string& option) const;

  // Writes the output of `option` to a temporary beside its final path: write(tmp) must
  // create tmp (the temporary keeps the final name's extensions, for writers that choose
  // the format from them).
  void Stage(const std::string& option, const std::function<void(const std::filesystem::path& tmp)>& write);
  void StageText(const std::string& option, const std::string& text);

  // Renames every staged output into place (and prints the "-" ones); outputs declared
  // but not staged are not written.
  void Commit();

 private:
  struct Output {
    std::string option;
    std::filesystem::path path;
    int flags = kNone;
    std::filesystem::path temporary;  // once staged
    std::string text;                 // staged text for "-"
    bool staged = false;
  };
  Output& Find(const std::string& option);

  std::vector<Named> inputs_;
  std::vector<Output> outputs_;
  bool committed_ = false;
};

// A part id as a file or folder name: characters outside [A-Za-z0-9._-] become '_', and so
// does a leading '.' (no "..", no hidden names); "" becomes "_"; at most 100 characters.
// ("../../escape" -> "_._.._escape" stays inside the folder it is written to.)
std::string SafeFileName(const std::string& id);
// `name`, or `name-2`, `name-3`, ... when `taken` already has it; the result is added.
std::string UniqueFileName(const std::string& name, std::set<std::string>* taken);

}  // namespace flatscan
