#include "flatscan/exe/cli.h"

#include <iostream>

namespace flatscan {
int RunCli(int, char**) {
  std::cout << "flatscan\n";
  return 0;
}
}  // namespace flatscan
