#include "sim/cli.h"

#include <CLI/CLI.hpp>

namespace restir {

int RunCommandLine(int argc, char** argv) {
  CLI::App app{"restir-sim: deterministic ReSTIR DI simulator"};
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  return 0;
}

}  // namespace restir
