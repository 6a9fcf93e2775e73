// The `restir-sim` command line: run, validate, presets.
#pragma once

namespace restir {

// Parses argv and runs the chosen command. Returns the process exit status: 0 success, 1 failure while
// running, 2 bad input (message already printed).
int RunCommandLine(int argc, char** argv);

}  // namespace restir
