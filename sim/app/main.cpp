#include <csignal>

#include "sim/app/cli.h"

int main(int argc, char** argv) {
  // Past a file-size limit (ulimit -f) a write should fail with EFBIG and be reported like a full disk (exit 2,
  // naming the file), not kill the process with SIGXFSZ half-way through.
  std::signal(SIGXFSZ, SIG_IGN);
  return restir::RunCommandLine(argc, argv);
}
