// MP4 videos of a run (H.264, yuv420p: what every browser plays), encoded by Debian's `ffmpeg` tool from frames
// this program composes, piped to it as raw RGB. The frames are deterministic; so are the files for one ffmpeg
// build (one encoder thread, bit-exact muxing, no metadata), though not across ffmpeg versions.
#pragma once

#include <sys/types.h>

#include <cstdio>
#include <optional>
#include <string>
#include <vector>

namespace restir {

// The ffmpeg executable: $RESTIR_FFMPEG when set (empty: none, for tests of its absence), else `ffmpeg` on PATH;
// nullopt when there is none.
std::optional<std::string> FindFfmpeg();

// One video being written: frames in order, each width x height x 3 bytes (rows top to bottom). Width and height
// must be even (yuv420p). ffmpeg writes to the system's temporary directory; Finish puts the file in place with
// WriteFileAtomic, so a video is whole or absent.
class VideoEncoder {
 public:
  VideoEncoder(const std::string& ffmpeg, const std::string& path, int width, int height, double fps);
  ~VideoEncoder();  // without a successful Finish: stops ffmpeg and removes its temporary file and log
  VideoEncoder(const VideoEncoder&) = delete;
  VideoEncoder& operator=(const VideoEncoder&) = delete;

  // Throws OutputError (exit status 2, naming the video) when ffmpeg has gone, its message included.
  void AddFrame(const std::vector<unsigned char>& rgb);
  // Waits for ffmpeg; throws OutputError naming the video with ffmpeg's message when it failed.
  void Finish();

 private:
  void Stop();

  std::string path_, temporary_, log_;
  int width_, height_;
  pid_t pid_ = -1;
  FILE* pipe_ = nullptr;
  bool finished_ = false;  // renamed into place: nothing to clean up
};

// An 8-bit RGB canvas for composing video frames: panels copied in, halved, captioned.
struct Canvas {
  int width = 0, height = 0;
  std::vector<unsigned char> rgb;  // 3 bytes a pixel, rows top to bottom

  Canvas(int w, int h, unsigned char grey);
  // Copies `src` (w x h RGB) with its top-left at (x, y), clipped.
  void Paste(const std::vector<unsigned char>& src, int w, int h, int x, int y);
  void Paste(const Canvas& src, int x, int y) { Paste(src.rgb, src.width, src.height, x, y); }
};
// `src` at half size (each output pixel the rounded mean of a 2x2 block; an odd last row or column dropped).
Canvas Halve(const Canvas& src);

}  // namespace restir
