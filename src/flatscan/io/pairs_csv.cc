#include "flatscan/io/pairs_csv.h"

#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "flatscan/util/error.h"

namespace flatscan {

std::vector<PairEntry> ReadPairsCsv(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) ThrowInputError("{}: cannot open pairs file (expected a CSV with columns id,left,right)", path.string());
  const std::filesystem::path base = path.parent_path();
  std::vector<PairEntry> out;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    std::vector<std::string> cols;
    std::stringstream s(line);
    for (std::string c; std::getline(s, c, ',');) cols.push_back(c);
    if (number == 1 && cols.size() == 3 && cols[0] == "id") continue;
    if (cols.size() != 3)
      ThrowInputError("{}: line {} has {} columns (expected 3: id,left,right)", path.string(), number, cols.size());
    auto resolve = [&](const std::string& p) { return std::filesystem::path(p).is_absolute() ? p : (base / p).string(); };
    out.push_back({cols[0], resolve(cols[1]), resolve(cols[2])});
  }
  if (out.empty()) ThrowInputError("{}: no pairs listed (expected lines id,left,right)", path.string());
  return out;
}

std::string PairsCsvText(const std::vector<PairEntry>& pairs) {
  std::string text = "id,left,right\n";
  for (const PairEntry& p : pairs) text += fmt::format("{},{},{}\n", p.id, p.left, p.right);
  return text;
}

}  // namespace flatscan
