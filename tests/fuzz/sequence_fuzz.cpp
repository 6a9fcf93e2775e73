// libFuzzer target for the sequence parser (DESIGN §10): any byte string given to ParseSequence must either
// parse or throw InputError. Anything else (a crash, another exception, a hang, an ASan/UBSan report, a huge
// allocation) is a bug that libFuzzer reports. Built by the `fuzz` preset, run by scripts/fuzz.sh.
//
// Relative mesh and asset paths resolve against the repository's data/ directory, so inputs derived from the
// shipped sequences ("meshes/tetra.obj") also exercise the importer (Assimp in a forked child,
// sim/assets/asset_import.h; importer_child.h keeps libFuzzer's handlers out of that child). The parser itself
// refuses anything that is not a regular file, so a mutated path such as "/dev/zero" cannot block the run.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_message.h"
#include "importer_child.h"
#include "sim/scene/sequence.h"

RESTIR_FUZZ_SANITIZER_DEFAULTS

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  restir::fuzz::InstallImporterChildHandler();
  return 0;
}

#ifndef RESTIR_FUZZ_DATA_DIR
#define RESTIR_FUZZ_DATA_DIR "data"
#endif

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const restir::Sequence seq = restir::ParseSequence(text, "fuzz.json", RESTIR_FUZZ_DATA_DIR);
    // A sequence that parses must also evaluate at its first and last frame (what every run does first).
    (void)restir::Evaluate(seq, 0, seq.width, seq.height);
    (void)restir::Evaluate(seq, seq.frameCount - 1, seq.width, seq.height);
  } catch (const restir::InputError& e) {
    // The expected outcome for bad input: one message on one line (the command line prints it as is).
    const std::string message = e.what();
    if (!IsOneCleanLine(message)) __builtin_trap();
  }
  return 0;
}
