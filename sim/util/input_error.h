// Bad input: one message that names the file and line:column and/or the JSON path. The command line prints
// what() and exits with status 2. Every reader throws it; it lives here, below them all, so that a reader of bytes
// needs nothing of the scene to refuse them.
#pragma once

#include <stdexcept>

namespace restir {

class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace restir
