#include "flatscan/exe/cli.h"

int main(int argc, char** argv) { return flatscan::RunCli(argc, argv); }
