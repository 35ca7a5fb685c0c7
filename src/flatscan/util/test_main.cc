// The test binary's main(): GoogleTest's, with TBB's workers joined before exit
// (util/worker_threads.h says why).
#include <gtest/gtest.h>

#include "flatscan/util/worker_threads.h"

int main(int argc, char** argv) {
  int failed = 0;
  {
    flatscan::JoinWorkerThreadsAtExit join_workers;
    testing::InitGoogleTest(&argc, argv);
    failed = RUN_ALL_TESTS();
  }
  return failed;
}
