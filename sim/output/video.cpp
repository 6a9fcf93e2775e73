#include "sim/output/video.h"

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "sim/util/atomic_file.h"
#include "sim/util/input_file.h"
#include "sim/util/text.h"

extern char** environ;

namespace restir {

namespace fs = std::filesystem;

std::optional<std::string> FindFfmpeg() {
  if (const char* forced = std::getenv("RESTIR_FFMPEG")) {
    if (*forced == '\0' || ::access(forced, X_OK) != 0) return std::nullopt;
    return std::string(forced);
  }
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "/usr/bin:/bin");
  for (std::string dir; std::getline(dirs, dir, ':');) {
    const std::string candidate = (dir.empty() ? std::string(".") : dir) + "/ffmpeg";
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return std::nullopt;
}

namespace {

// ffmpeg's own files go to the system's temporary directory, not beside the video: the run's output directory only
// ever receives whole files through WriteFileAtomic, whoever else writes there at the same time.
std::string ScratchPath(const std::string& suffix) {
  static std::atomic<int> counter{0};
  char name[96];
  std::snprintf(name, sizeof(name), "restir-sim-video-%d-%d%s", static_cast<int>(::getpid()), counter++,
                suffix.c_str());
  std::error_code ec;
  fs::path dir = fs::temp_directory_path(ec);
  if (ec) dir = "/tmp";  // TMPDIR names no directory
  return (dir / name).string();
}

// ffmpeg ending early closes the pipe: a write to it raises SIGPIPE, which would end this process. Blocked in the
// writing thread only (other threads write other videos at the same time), the signal stays pending and the write
// fails with EPIPE; the pending signal is taken before the mask is restored.
class SigpipeBlocked {
 public:
  SigpipeBlocked() {
    sigemptyset(&pipe_);
    sigaddset(&pipe_, SIGPIPE);
    pthread_sigmask(SIG_BLOCK, &pipe_, &previous_);
  }
  ~SigpipeBlocked() {
    sigset_t pending;
    sigpending(&pending);
    if (sigismember(&pending, SIGPIPE) && !sigismember(&previous_, SIGPIPE)) {
      const timespec now{0, 0};
      sigtimedwait(&pipe_, nullptr, &now);
    }
    pthread_sigmask(SIG_SETMASK, &previous_, nullptr);
  }
  SigpipeBlocked(const SigpipeBlocked&) = delete;
  SigpipeBlocked& operator=(const SigpipeBlocked&) = delete;

 private:
  sigset_t pipe_, previous_;
};

}  // namespace

VideoEncoder::VideoEncoder(const std::string& ffmpeg, const std::string& path, int width, int height, double fps)
    : path_(path), temporary_(ScratchPath(".mp4")), log_(ScratchPath(".log")), width_(width), height_(height) {
  if (width < 2 || height < 2 || width % 2 || height % 2)
    throw std::runtime_error(path + ": a video's width and height must be even");
  char size[32], rate[32];
  std::snprintf(size, sizeof(size), "%dx%d", width, height);
  std::snprintf(rate, sizeof(rate), "%.6g", fps);
  // One encoder thread and bit-exact muxing: the same frames give the same file with this ffmpeg. BT.709, as a
  // browser assumes for video; CRF 18 keeps the noise the videos exist to show.
  std::vector<std::string> args = {ffmpeg, "-nostdin", "-hide_banner", "-loglevel", "error", "-y",
                                   "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", size, "-framerate", rate,
                                   "-i", "pipe:0",
                                   "-vf", "scale=out_color_matrix=bt709:out_range=tv:flags=bicubic,format=yuv420p",
                                   "-c:v", "libx264", "-preset", "veryfast", "-crf", "18", "-threads", "1",
                                   "-colorspace", "bt709", "-color_primaries", "bt709", "-color_trc", "bt709",
                                   "-color_range", "tv", "-movflags", "+faststart", "-map_metadata", "-1",
                                   "-fflags", "+bitexact", "-flags:v", "+bitexact", "-f", "mp4", temporary_};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0)
    throw OutputError(path + ": error: cannot write (cannot start ffmpeg: " + std::strerror(errno) + ")");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[0], STDIN_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  const int rc = ::posix_spawn(&pid_, ffmpeg.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(fds[0]);
  if (rc != 0) {
    ::close(fds[1]);
    pid_ = -1;
    std::error_code ec;
    fs::remove(log_, ec);  // the spawn may have opened it before exec failed
    throw OutputError(path + ": error: cannot write (cannot start " + ffmpeg + ": " + std::strerror(rc) + ")");
  }
  pipe_ = ::fdopen(fds[1], "wb");
  if (!pipe_) {
    ::close(fds[1]);
    Stop();
    std::error_code ec;
    fs::remove(temporary_, ec);
    fs::remove(log_, ec);
    throw OutputError(path + ": error: cannot write (no pipe to ffmpeg)");
  }
}

VideoEncoder::~VideoEncoder() {
  if (finished_) return;
  Stop();
  std::error_code ec;
  fs::remove(temporary_, ec);
  fs::remove(log_, ec);
}

void VideoEncoder::Stop() {
  if (pipe_) std::fclose(pipe_);
  pipe_ = nullptr;
  if (pid_ > 0) {
    ::kill(pid_, SIGTERM);
    int status = 0;
    while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
  }
  pid_ = -1;
}

namespace {

std::string FfmpegMessage(const std::string& log) {
  std::ifstream in(log);
  std::stringstream s;
  s << in.rdbuf();
  std::string text = s.str();
  if (text.size() > 600) text = "..." + text.substr(text.size() - 600);
  return OneLine(text.empty() ? std::string("no message") : text);
}

}  // namespace

void VideoEncoder::AddFrame(const std::vector<unsigned char>& rgb) {
  if (!pipe_) throw std::runtime_error(path_ + ": ffmpeg has already failed");
  if (rgb.size() != static_cast<size_t>(width_) * height_ * 3)
    throw std::runtime_error(path_ + ": a frame of the wrong size");
  size_t n = 0;
  {
    const SigpipeBlocked blocked;
    n = std::fwrite(rgb.data(), 1, rgb.size(), pipe_);
  }
  if (n != rgb.size()) {
    const std::string message = FfmpegMessage(log_);
    Stop();
    throw OutputError(path_ + ": error: cannot write (ffmpeg stopped reading frames: " + message + ")");
  }
}

void VideoEncoder::Finish() {
  if (!pipe_ || pid_ <= 0) throw std::runtime_error(path_ + ": ffmpeg has already failed");
  bool flushed = false;
  {
    const SigpipeBlocked blocked;
    flushed = std::fclose(pipe_) == 0;
  }
  pipe_ = nullptr;
  int status = 0;
  while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
  pid_ = -1;
  const bool ok = flushed && WIFEXITED(status) && WEXITSTATUS(status) == 0;
  std::error_code ec;
  if (!ok) {
    const std::string message = FfmpegMessage(log_);
    fs::remove(temporary_, ec);
    fs::remove(log_, ec);
    throw OutputError(path_ + ": error: cannot write (ffmpeg failed: " + message + ")");
  }
  fs::remove(log_, ec);
  std::string bytes, problem;
  const bool read = TryReadRegularFile(temporary_, size_t(1) << 34, bytes, problem);
  fs::remove(temporary_, ec);
  finished_ = true;
  if (!read) throw OutputError(path_ + ": error: cannot write (cannot read what ffmpeg wrote: " + problem + ")");
  WriteFileAtomic(path_, bytes);
}

Canvas::Canvas(int w, int h, unsigned char grey)
    : width(w), height(h), rgb(static_cast<size_t>(w) * h * 3, grey) {}

void Canvas::Paste(const std::vector<unsigned char>& src, int w, int h, int x, int y) {
  for (int sy = 0; sy < h; ++sy) {
    const int dy = y + sy;
    if (dy < 0 || dy >= height) continue;
    for (int sx = 0; sx < w; ++sx) {
      const int dx = x + sx;
      if (dx < 0 || dx >= width) continue;
      std::memcpy(&rgb[(static_cast<size_t>(dy) * width + dx) * 3], &src[(static_cast<size_t>(sy) * w + sx) * 3], 3);
    }
  }
}

Canvas Halve(const Canvas& src) {
  Canvas out(src.width / 2, src.height / 2, 0);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x)
      for (int c = 0; c < 3; ++c) {
        auto at = [&](int sx, int sy) { return int(src.rgb[(static_cast<size_t>(sy) * src.width + sx) * 3 + c]); };
        const int sum = at(2 * x, 2 * y) + at(2 * x + 1, 2 * y) + at(2 * x, 2 * y + 1) + at(2 * x + 1, 2 * y + 1);
        out.rgb[(static_cast<size_t>(y) * out.width + x) * 3 + c] = static_cast<unsigned char>((sum + 2) / 4);
      }
  return out;
}

}  // namespace restir
