// The sky of a frame (core/sky.h Sky) from the sequence's environment and sun and the frame's state.
#pragma once

#include "core/sky.h"
#include "sim/scene/sequence.h"

namespace restir {

// Builds `environment.sampler` from `environment.map`. The sequence reader calls it; code that builds a
// Sequence by hand calls it after setting the map.
void PrepareEnvironment(Environment& environment);

// The sky at `state`'s frame. Points into `sequence` (the environment sampler), which must outlive it.
Sky MakeSky(const Sequence& sequence, const FrameState& state);

}  // namespace restir
