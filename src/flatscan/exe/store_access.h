#pragma once
// Opening a results store named on the command line, to read it: the SQLite file a
// station writes or the plant store (postgresql://...). Shared by the commands that read
// records (results, gauge).
#include <memory>
#include <string>

#include "flatscan/store/results_store.h"

namespace flatscan {

// Throws InputError under `flag` when the file does not exist or the store cannot be opened.
std::unique_ptr<ResultsStore> OpenStoreToRead(const std::string& store, const std::string& flag);

}  // namespace flatscan
