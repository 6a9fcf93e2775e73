// Screen-space cells of stochastic pairwise MIS (seed 004 §5), as built by the pipeline on the flagship.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "core/spmis.h"
#include "sim/scene/embree_scene.h"
#include "sim/scene/gbuffer.h"
#include "sim/estimator/pipeline.h"
#include "sim/scene/shading_point.h"
#include "sim/estimator/presets.h"
#include "sim/scene/sequence.h"

namespace restir {
namespace {

struct CellRun {
  GBuffer gbuffer;
  std::vector<int32_t> pixelCell;
  std::vector<uint32_t> cellPixels;
  size_t cells = 0;
};

// Two frames of restir-spmis on window_bars_pan at 96x54 with a thread limit; the cells of frame 1.
CellRun RunCells(int threads) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
  const Sequence seq = LoadSequence("sequences/window_bars_pan.json");
  EmbreeScene scene(seq);
  const std::vector<Bsdf> bsdfs = MaterialBsdfs(seq);
  Pipeline pipeline(FindPreset("restir-spmis")->settings);
  CellRun out;
  GBuffer previous;
  FrameState previousState;
  std::vector<LightTriangle> previousLights;
  for (int f = 0; f < 2; ++f) {
    const FrameState state = Evaluate(seq, f, 96, 54);
    scene.Update(state);
    GBuffer current;
    TracePrimary(scene, state.camera, current);
    Reproject(state, previousState, previous, scene.LightObjectId(), ReprojectionParams{}, current);
    const LightSampler lights(scene.LightTriangles(), LightSelection::kPower);
    FrameInputs in;
    in.state = &state;
    in.scene = &scene;
    in.gbuffer = &current;
    in.lights = &lights;
    in.materials = &bsdfs;
    in.seed = 3;
    in.frame = static_cast<uint32_t>(f);
    if (f > 0) in.previousState = &previousState, in.previousGbuffer = &previous, in.previousLights = &previousLights;
    pipeline.RenderFrame(in);
    out.gbuffer = current;
    previous = current;
    previousState = state;
    previousLights = scene.LightTriangles();
  }
  out.pixelCell = pipeline.Cells().pixelCell;
  out.cellPixels = pipeline.Cells().pixels;
  out.cells = pipeline.Cells().cells.size();
  return out;
}

// Every surface pixel is in exactly one cell, every other pixel in none; a cell's pixels share their tile and
// object id.
TEST(Cells, EverySurfacePixelInExactlyOneCell) {
  const CellRun r = RunCells(2);
  const GBuffer& g = r.gbuffer;
  ASSERT_GT(r.cells, 0u);
  std::vector<int> seen(g.Size(), 0);
  for (uint32_t p : r.cellPixels) seen[p] += 1;
  for (size_t i = 0; i < g.Size(); ++i) {
    EXPECT_EQ(seen[i], g.IsSurface(i) ? 1 : 0) << i;
    EXPECT_EQ(r.pixelCell[i] >= 0, g.IsSurface(i)) << i;
  }
  // Pixels sharing a cell share the 8x8 tile and the object id.
  for (size_t i = 0; i < g.Size(); ++i)
    for (size_t j = i + 1; j < std::min(g.Size(), i + 16); ++j)
      if (r.pixelCell[i] >= 0 && r.pixelCell[i] == r.pixelCell[j]) {
        EXPECT_EQ(g.objectId[i], g.objectId[j]);
        EXPECT_EQ((i % g.width) / 8, (j % g.width) / 8);
      }
}

TEST(Cells, IdenticalAcrossThreadCounts) {
  const CellRun a = RunCells(1), b = RunCells(2);
  EXPECT_EQ(a.cells, b.cells);
  EXPECT_EQ(a.pixelCell, b.pixelCell);
  EXPECT_EQ(a.cellPixels, b.cellPixels);
}

}  // namespace
}  // namespace restir
