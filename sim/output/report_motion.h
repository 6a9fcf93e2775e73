// The parts of report.html that show a run moving, all made from its scrub PNGs (sim/output/scrub_frames.h): the
// frame scrubber (a small script; without JavaScript the page shows the rest as before), the videos (an MP4 per
// preset of estimate | reference | error, and one of every preset side by side; sim/output/video.h) and the crops of
// what was revealed, enlarged.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace restir {

// What the motion sections read.
struct MotionInputs {
  std::string outDir;                // the run's output directory
  int width = 0, height = 0;         // the run's resolution (run.json)
  double fps = 30.0;                 // the sequence's frame rate (run.json), the videos' and the scrubber's
  bool hasReference = false;         // the scrub PNGs include the reference, error and FLIP layers
  std::vector<std::string> presets;  // in metrics.csv's order
  std::vector<int> frames;           // every frame of metrics.csv, sorted
  std::vector<int> postRevealFrames; // frames with disocc_recent_fraction > 0, sorted
};

// True when every scrub PNG the inputs name is on disk (a run with --no-images, or one from before the scrubber,
// has none: the motion sections then say so).
bool ScrubFramesPresent(const MotionInputs& in);

// The videos written (paths relative to the output directory) or why there are none.
struct Videos {
  std::vector<std::pair<std::string, std::string>> perPreset;  // preset -> videos/P.mp4
  std::string grid;                                            // videos/all_presets.mp4, or ""
  std::string note;                                            // why none were made, or ""
};
// Writes OUT/videos/<preset>.mp4 and all_presets.mp4 (each whole, through WriteFileAtomic; nothing else there is
// touched). Without ffmpeg, says so on stderr and in the note.
Videos WriteVideos(const MotionInputs& in);

// The enlarged region of the reveal: a rectangle of the frame, the frames shown, and each crop's file.
struct Crops {
  bool present = false;
  int x = 0, y = 0, width = 0, height = 0;  // the region, in pixels of the frame
  int scale = 1;                            // each pixel shown as scale x scale
  std::vector<int> frames;                  // the reveal frame and two after it
  std::string rule;                         // how the region was chosen, for the reader
  // [row][frame]: row 0 the reference (when there is one), then each preset's estimate and error; paths relative.
  std::vector<std::pair<std::string, std::vector<std::string>>> rows;
};
// Chooses the region from the disocclusion masks of the post-reveal frames and writes the crops under
// OUT/report_images/crops/.
Crops WriteCrops(const MotionInputs& in);

void HtmlScrubber(std::ostream& o, const MotionInputs& in);
void HtmlVideos(std::ostream& o, const Videos& v);
void HtmlCrops(std::ostream& o, const Crops& c);
// summary.json's "videos" and "crop".
nlohmann::ordered_json VideosJson(const Videos& v);
nlohmann::ordered_json CropsJson(const Crops& c);

}  // namespace restir
