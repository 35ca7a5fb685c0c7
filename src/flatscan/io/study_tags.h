#pragma once
// Where a measurement stands in a gauge study (docs/gauge.md): which part, which appraiser
// (an operator, or a station), which trial. A pairs file gives them per pair (columns
// part, appraiser, trial: io/pairs_csv.h); the station keeps them in the pair's record
// (JSON key "study"), from which `flatscan gauge ... --store` builds the study. Kept in
// io/, below the files and records that carry the tags and the studies that read them.
#include <string>

namespace flatscan {

struct StudyTags {
  std::string part, appraiser, trial;
  bool Empty() const { return part.empty() && appraiser.empty() && trial.empty(); }
  bool operator==(const StudyTags&) const = default;
};

}  // namespace flatscan
