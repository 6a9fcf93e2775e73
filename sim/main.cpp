#include "sim/cli.h"

int main(int argc, char** argv) { return restir::RunCommandLine(argc, argv); }
