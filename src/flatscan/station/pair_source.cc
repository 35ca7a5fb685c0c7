#include "flatscan/station/pair_source.h"

#include <thread>
#include <vector>

#include <spdlog/spdlog.h>

#include "flatscan/io/pairs_csv.h"
#include "flatscan/station/folder_source.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

class PairsFileSource : public PairSource {
 public:
  explicit PairsFileSource(const std::filesystem::path& csv) : name_("pairs:" + csv.string()), pairs_(ReadPairsCsv(csv)) {
    for (const PairEntry& p : pairs_)
      if (p.thickness_mm) {
        spdlog::warn("{}: its thickness column is not used: a station measures with the recipe's thickness_mm",
                     csv.string());
        break;
      }
  }
  std::optional<SourcePair> Next(std::chrono::milliseconds wait) override {
    if (next_ == pairs_.size()) {  // replayed: wait as asked, not spin
      std::this_thread::sleep_for(wait);
      return std::nullopt;
    }
    const PairEntry& p = pairs_[next_++];
    SourcePair pair = FilePair(p.id, p.left, p.right);
    pair.study = p.study;
    return pair;
  }
  bool Exhausted() const override { return next_ == pairs_.size(); }
  std::string Name() const override { return name_; }

 private:
  std::string name_;
  std::vector<PairEntry> pairs_;
  size_t next_ = 0;
};

}  // namespace

std::unique_ptr<PairSource> MakePairsFileSource(const std::filesystem::path& csv) {
  return std::make_unique<PairsFileSource>(csv);
}

std::unique_ptr<PairSource> MakePairSource(const std::string& spec, const FolderSourceOptions& folder) {
  const auto colon = spec.find(':');
  const std::string kind = spec.substr(0, colon), where = colon == std::string::npos ? "" : spec.substr(colon + 1);
  if (kind == "pairs" && !where.empty()) return MakePairsFileSource(where);
  if (kind == "folder" && !where.empty()) return MakeFolderSource(where, folder);
  ThrowInputError("--source '{}': expected folder:DIR (a folder to watch), pairs:FILE.csv (a pairs file to replay), "
                  "cameras:LEFT,RIGHT (two cameras) or aravis-fake:DIR (fake cameras showing a dataset)",
                  spec);
}

}  // namespace flatscan
