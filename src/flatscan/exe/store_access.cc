#include "flatscan/exe/store_access.h"

#include <filesystem>

#include "flatscan/store/postgres_results_store.h"
#include "flatscan/util/error.h"

namespace flatscan {

std::unique_ptr<ResultsStore> OpenStoreToRead(const std::string& store, const std::string& flag) {
  const bool plant = IsPostgresUri(store);
  if (!plant && !std::filesystem::is_regular_file(store)) ThrowInputError("{} '{}': no such results store", flag, store);
  try {
    if (plant) return std::make_unique<PostgresResultsStore>(store, "", false);
    return OpenSqliteStore(store, false);
  } catch (const StoreError& e) {
    ThrowInputError("{}: {}", flag, e.what());
  } catch (const InputError& e) {  // a URI libpq cannot parse
    ThrowInputError("{}: {}", flag, e.what());
  }
}

}  // namespace flatscan
