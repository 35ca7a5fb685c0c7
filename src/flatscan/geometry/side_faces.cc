#include "flatscan/geometry/side_faces.h"

#include "flatscan/util/error.h"

namespace flatscan {

std::string SideFaceModelName(SideFaceModel model) {
  switch (model) {
    case SideFaceModel::kLocalNormal: return "local";
    case SideFaceModel::kCentreNormal: return "centre";
    case SideFaceModel::kSupportNormal: return "support";
  }
  return "local";
}

SideFaceModel ParseSideFaceModel(const std::string& name) {
  for (SideFaceModel m : {SideFaceModel::kLocalNormal, SideFaceModel::kCentreNormal, SideFaceModel::kSupportNormal})
    if (name == SideFaceModelName(m)) return m;
  ThrowInputError("unknown side-face model '{}' (expected local: perpendicular to the sheet at each point, centre: "
                  "along the sheet's normal at the part's centre, or support: along the support plane's normal)",
                  name);
}

}  // namespace flatscan
