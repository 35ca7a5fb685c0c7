#include "flatscan/exe/cli.h"
#include "flatscan/util/worker_threads.h"

int main(int argc, char** argv) {
  int exit_code = 0;
  {
    flatscan::JoinWorkerThreadsAtExit join_workers;
    exit_code = flatscan::RunCli(argc, argv);
  }
  return exit_code;
}
