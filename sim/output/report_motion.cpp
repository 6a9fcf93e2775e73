#include "sim/output/report_motion.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <tbb/parallel_for.h>

#include "sim/output/bitmap_font.h"
#include "sim/output/frame_writer.h"
#include "sim/output/png_encode.h"
#include "sim/output/scrub_frames.h"
#include "sim/output/video.h"
#include "sim/util/atomic_file.h"
#include "sim/util/text.h"

namespace restir {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

namespace {

std::string Path(const MotionInputs& in, const std::string& relative) {
  return (fs::path(in.outDir) / relative).string();
}

std::vector<unsigned char> Read(const MotionInputs& in, const std::string& relative) {
  return ReadScrubPng(Path(in, relative), in.width, in.height);
}

// ---- videos ----

constexpr unsigned char kBand = 24;  // the caption band's grey
const unsigned char kInk[3] = {235, 235, 235};

int FontScale(int panelWidth) { return panelWidth >= 320 ? 2 : 1; }
int BandHeight(int scale) { return (kGlyphHeight + 4) * scale + 2; }
int Even(int v) { return v + (v & 1); }

// A panel of the run's size, halved `halvings` times.
Canvas Panel(std::vector<unsigned char> rgb, int w, int h, int halvings) {
  Canvas c(w, h, 0);
  c.rgb = std::move(rgb);
  for (int k = 0; k < halvings; ++k) c = Halve(c);
  return c;
}

void Caption(Canvas& c, int x, int y, const std::string& text, int scale) {
  DrawText(c.rgb, c.width, c.height, x + 2 * scale, y + 2 * scale, text, scale, kInk);
}

std::string FrameText(int frame, int last) { return "frame " + std::to_string(frame) + "/" + std::to_string(last); }

// One preset's video: estimate | reference | error, a caption band above with the frame number.
void WritePresetVideo(const MotionInputs& in, const std::string& ffmpeg, const std::string& preset,
                      const std::string& relative) {
  const int panels = in.hasReference ? 3 : 1;
  int halvings = 0;
  while ((in.width >> halvings) * panels > 3840 && (in.width >> halvings) > 64) ++halvings;
  const int pw = in.width >> halvings, ph = in.height >> halvings, scale = FontScale(pw), band = BandHeight(scale);
  VideoEncoder video(ffmpeg, Path(in, relative), Even(pw * panels), Even(ph + band), in.fps);
  for (int frame : in.frames) {
    Canvas c(Even(pw * panels), Even(ph + band), kBand);
    c.Paste(Panel(Read(in, ScrubPresetPath(preset, frame, ScrubLayer::kEstimate)), in.width, in.height, halvings), 0,
            band);
    Caption(c, 0, 0, preset + "  " + FrameText(frame, in.frames.back()), scale);
    if (in.hasReference) {
      c.Paste(Panel(Read(in, ScrubReferencePath(frame)), in.width, in.height, halvings), pw, band);
      c.Paste(Panel(Read(in, ScrubPresetPath(preset, frame, ScrubLayer::kError)), in.width, in.height, halvings),
              2 * pw, band);
      Caption(c, pw, 0, "reference", scale);
      Caption(c, 2 * pw, 0, "error 0-1", scale);
    }
    video.AddFrame(c.rgb);
  }
  video.Finish();
}

// Every preset's estimate (and the reference) in a grid, at most 1920 pixels wide.
void WriteGridVideo(const MotionInputs& in, const std::string& ffmpeg, const std::string& relative) {
  std::vector<std::string> tiles;
  if (in.hasReference) tiles.push_back("");  // "" is the reference
  tiles.insert(tiles.end(), in.presets.begin(), in.presets.end());
  const int n = static_cast<int>(tiles.size());
  const int cols = static_cast<int>(std::ceil(std::sqrt(double(n)))), rows = (n + cols - 1) / cols;
  int halvings = 0;
  while ((in.width >> halvings) * cols > 1920 && (in.width >> halvings) > 64) ++halvings;
  const int pw = in.width >> halvings, ph = in.height >> halvings, scale = FontScale(pw), band = BandHeight(scale);
  const int topScale = FontScale(pw * cols), top = BandHeight(topScale);
  const int w = Even(pw * cols), h = Even(top + rows * (ph + band));
  VideoEncoder video(ffmpeg, Path(in, relative), w, h, in.fps);
  for (int frame : in.frames) {
    Canvas c(w, h, kBand);
    Caption(c, 0, 0, "all presets  " + FrameText(frame, in.frames.back()), topScale);
    for (int k = 0; k < n; ++k) {
      const int x = (k % cols) * pw, y = top + (k / cols) * (ph + band);
      const std::string source = tiles[k].empty() ? ScrubReferencePath(frame)
                                                  : ScrubPresetPath(tiles[k], frame, ScrubLayer::kEstimate);
      c.Paste(Panel(Read(in, source), in.width, in.height, halvings), x, y + band);
      Caption(c, x, y, tiles[k].empty() ? "reference" : tiles[k], scale);
    }
    video.AddFrame(c.rgb);
  }
  video.Finish();
}

// ---- crops ----

// The post-reveal frames' disocclusion masks, one byte a pixel, read once for both uses below.
std::vector<std::vector<unsigned char>> RevealMasks(const MotionInputs& in) {
  std::vector<std::vector<unsigned char>> masks;
  for (int frame : in.postRevealFrames) {
    const std::vector<unsigned char> rgb = Read(in, ScrubDisocclusionPath(frame));
    std::vector<unsigned char>& mask = masks.emplace_back(rgb.size() / 3);
    for (size_t i = 0; i < mask.size(); ++i) mask[i] = rgb[3 * i];
  }
  return masks;
}

// Per pixel, how many of the masks mark it revealed (recently or now).
std::vector<int> RevealCounts(const std::vector<std::vector<unsigned char>>& masks, size_t pixels) {
  std::vector<int> count(pixels, 0);
  for (const std::vector<unsigned char>& mask : masks)
    for (size_t i = 0; i < pixels; ++i) count[i] += mask[i] >= kScrubRevealedRecently;
  return count;
}

// The densest cw x ch window of `count` inside [x0, x1) x [y0, y1) (a summed-area table; first best in scan order).
void DensestWindow(const std::vector<int>& count, int w, int x0, int y0, int x1, int y1, int cw, int ch, int& bx,
                   int& by) {
  const int h = static_cast<int>(count.size()) / w;
  std::vector<int64_t> sat(static_cast<size_t>(w + 1) * (h + 1), 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      sat[(y + 1) * size_t(w + 1) + x + 1] = count[y * size_t(w) + x] + sat[y * size_t(w + 1) + x + 1] +
                                             sat[(y + 1) * size_t(w + 1) + x] - sat[y * size_t(w + 1) + x];
  auto sum = [&](int x, int y) {
    return sat[(y + ch) * size_t(w + 1) + x + cw] - sat[y * size_t(w + 1) + x + cw] -
           sat[(y + ch) * size_t(w + 1) + x] + sat[y * size_t(w + 1) + x];
  };
  int64_t best = -1;
  bx = x0, by = y0;
  for (int y = y0; y + ch <= y1; ++y)
    for (int x = x0; x + cw <= x1; ++x)
      if (const int64_t s = sum(x, y); s > best) best = s, bx = x, by = y;
}

std::vector<unsigned char> CropScaled(const std::vector<unsigned char>& rgb, int w, const Crops& c) {
  const int ow = c.width * c.scale, oh = c.height * c.scale;
  std::vector<unsigned char> out(static_cast<size_t>(ow) * oh * 3);
  for (int y = 0; y < oh; ++y)
    for (int x = 0; x < ow; ++x) {
      const size_t src = (static_cast<size_t>(c.y + y / c.scale) * w + c.x + x / c.scale) * 3;
      std::copy(&rgb[src], &rgb[src] + 3, &out[(static_cast<size_t>(y) * ow + x) * 3]);
    }
  return out;
}

// The scrubber's script: state in the address's fragment (#frame=F&layer=L&presets=a,b&zoom=Z&x=X&y=Y), so a link
// shows a frame; every panel shares one view (zoom about the pointer with the wheel, pan by dragging).
const char* kScrubberScript = R"JS(
(function () {
  var S = JSON.parse(document.getElementById("scrub-data").textContent);
  var root = document.getElementById("scrubber");
  var slider = document.getElementById("scrub-frame");
  var label = document.getElementById("scrub-label");
  var playButton = document.getElementById("scrub-play");
  var panels = document.getElementById("scrub-panels");
  var fit = Math.min(1, S.view / S.width);
  var st = {index: 0, layer: "estimate", presets: S.presets.slice(), zoom: fit, x: 0, y: 0};
  var timer = null, hashTimer = null, views = [];
  function pad(f) { var s = String(f); while (s.length < 4) s = "0" + s; return s; }
  function src(preset, frame, layer) {
    if (layer === "reference") return "scrub/reference/" + pad(frame) + ".png";
    if (layer === "disocclusion") return "scrub/disocclusion/" + pad(frame) + ".png";
    return "scrub/presets/" + encodeURIComponent(preset) + "/" + pad(frame) + "_" + layer + ".png";
  }
  function readHash() {
    var h = location.hash.replace(/^#/, "").split("&"), i, kv;
    for (i = 0; i < h.length; ++i) {
      kv = h[i].split("=");
      var v = decodeURIComponent(kv[1] || "");
      if (kv[0] === "frame") { var k = S.frames.indexOf(parseInt(v, 10)); if (k >= 0) st.index = k; }
      else if (kv[0] === "layer" && S.layers.indexOf(v) >= 0) st.layer = v;
      else if (kv[0] === "presets") st.presets = v.split(",").filter(function (p) { return S.presets.indexOf(p) >= 0; });
      else if (kv[0] === "zoom" && parseFloat(v) > 0) st.zoom = parseFloat(v);
      else if (kv[0] === "x" && isFinite(parseFloat(v))) st.x = parseFloat(v);
      else if (kv[0] === "y" && isFinite(parseFloat(v))) st.y = parseFloat(v);
    }
    return /(^|&)frame=/.test(location.hash.replace(/^#/, ""));
  }
  // The address follows what is shown, a quarter second late: Firefox refuses more than 200 replaceState calls in
  // 10 s (playing is 30 a second), and a link to a section (#plots) stays as it is until the reader moves something.
  function writeHash() {
    if (hashTimer) return;
    hashTimer = setTimeout(function () {
      hashTimer = null;
      var h = "#frame=" + S.frames[st.index] + "&layer=" + st.layer + "&presets=" +
              st.presets.map(encodeURIComponent).join(",");
      if (st.zoom !== fit || st.x !== 0 || st.y !== 0) h += "&zoom=" + st.zoom + "&x=" + st.x + "&y=" + st.y;
      try { if (history.replaceState) history.replaceState(null, "", h); } catch (e) { /* refused: keep showing */ }
    }, 250);
  }
  function applyView() {
    views.forEach(function (v) {
      v.img.style.transform = "translate(" + st.x + "px," + st.y + "px) scale(" + st.zoom + ")";
    });
  }
  function show(moved) {
    var frame = S.frames[st.index];
    slider.value = st.index;
    label.textContent = "frame " + frame + " (" + (st.index + 1) + " of " + S.frames.length + ")";
    views.forEach(function (v) {
      var shown = st.presets.indexOf(v.preset) >= 0;
      v.fig.style.display = shown ? "" : "none";
      if (!shown) return;  // a hidden panel loads nothing
      v.img.src = src(v.preset, frame, st.layer);
      v.img.alt = v.preset + " frame " + frame + " " + st.layer;
    });
    Array.prototype.forEach.call(root.querySelectorAll("input[name=scrub-layer]"), function (r) {
      r.checked = r.value === st.layer;
    });
    Array.prototype.forEach.call(root.querySelectorAll("input[name=scrub-preset]"), function (c) {
      c.checked = st.presets.indexOf(c.value) >= 0;
    });
    applyView();
    if (moved) writeHash();
    var next = S.frames[(st.index + 1) % S.frames.length];  // the next frame, fetched while this one shows
    st.presets.forEach(function (p) { new Image().src = src(p, next, st.layer); });
  }
  S.presets.forEach(function (preset) {
    var fig = document.createElement("figure"), cap = document.createElement("figcaption");
    var view = document.createElement("div"), img = document.createElement("img");
    fig.className = "scrub-panel";
    cap.textContent = preset;
    view.className = "scrub-view";
    view.style.width = Math.round(S.width * fit) + "px";
    view.style.height = Math.round(S.height * fit) + "px";
    img.className = "scrub-image";
    img.width = S.width;
    img.height = S.height;
    img.draggable = false;
    view.appendChild(img);
    fig.appendChild(cap);
    fig.appendChild(view);
    panels.appendChild(fig);
    views.push({preset: preset, fig: fig, img: img});
    view.addEventListener("wheel", function (e) {
      e.preventDefault();
      var r = view.getBoundingClientRect(), px = e.clientX - r.left, py = e.clientY - r.top;
      var z = Math.min(64, Math.max(fit, st.zoom * (e.deltaY < 0 ? 1.25 : 0.8)));
      st.x = px - (px - st.x) * z / st.zoom;
      st.y = py - (py - st.y) * z / st.zoom;
      st.zoom = z;
      applyView();
      writeHash();
    }, {passive: false});
    view.addEventListener("mousedown", function (e) {
      e.preventDefault();
      var sx = e.clientX - st.x, sy = e.clientY - st.y;
      function move(m) { st.x = m.clientX - sx; st.y = m.clientY - sy; applyView(); }
      function up() { window.removeEventListener("mousemove", move); window.removeEventListener("mouseup", up); writeHash(); }
      window.addEventListener("mousemove", move);
      window.addEventListener("mouseup", up);
    });
  });
  slider.max = S.frames.length - 1;
  slider.addEventListener("input", function () { st.index = parseInt(slider.value, 10); show(true); });
  Array.prototype.forEach.call(root.querySelectorAll("input[name=scrub-layer]"), function (r) {
    r.addEventListener("change", function () { st.layer = r.value; show(true); });
  });
  Array.prototype.forEach.call(root.querySelectorAll("input[name=scrub-preset]"), function (c) {
    c.addEventListener("change", function () {
      st.presets = S.presets.filter(function (p) {
        return root.querySelector("input[name=scrub-preset][value='" + p + "']").checked;
      });
      show(true);
    });
  });
  function play(on) {
    if (timer) { clearInterval(timer); timer = null; }
    if (on) timer = setInterval(function () { st.index = (st.index + 1) % S.frames.length; show(true); }, 1000 / S.fps);
    playButton.textContent = timer ? "pause" : "play";
  }
  playButton.addEventListener("click", function () { play(!timer); });
  document.getElementById("scrub-reset").addEventListener("click", function () {
    st.zoom = fit; st.x = 0; st.y = 0; applyView(); writeHash();
  });
  root.addEventListener("keydown", function (e) {
    if (e.target.tagName === "INPUT" && e.target.type !== "range") return;
    if (e.key === "ArrowRight" || e.key === "ArrowLeft") {
      e.preventDefault();
      st.index = (st.index + (e.key === "ArrowRight" ? 1 : S.frames.length - 1)) % S.frames.length;
      show(true);
    } else if (e.key === " " && e.target.tagName !== "BUTTON") {  // a focused button's space is its own click
      e.preventDefault();
      play(!timer);
    }
  });
  // A frame link pasted into an open report (replaceState, the scrubber's own writing, fires no hashchange).
  window.addEventListener("hashchange", function () { if (readHash()) show(false); });
  root.hidden = false;
  var linked = readHash();
  show(false);
  if (linked && root.getBoundingClientRect().top > window.innerHeight) root.scrollIntoView();
})();
)JS";

}  // namespace

bool ScrubFramesPresent(const MotionInputs& in) {
  if (in.frames.empty() || in.presets.empty() || in.width < 1 || in.height < 1) return false;
  std::error_code ec;
  for (int frame : in.frames) {
    std::vector<std::string> paths = {ScrubDisocclusionPath(frame)};
    if (in.hasReference) paths.push_back(ScrubReferencePath(frame));
    for (const std::string& p : in.presets) {
      paths.push_back(ScrubPresetPath(p, frame, ScrubLayer::kEstimate));
      if (in.hasReference)
        for (ScrubLayer l : {ScrubLayer::kError, ScrubLayer::kFlip}) paths.push_back(ScrubPresetPath(p, frame, l));
    }
    for (const std::string& path : paths)
      if (!fs::is_regular_file(Path(in, path), ec)) return false;
  }
  return true;
}

Videos WriteVideos(const MotionInputs& in) {
  Videos v;
  const std::optional<std::string> ffmpeg = FindFfmpeg();
  if (!ffmpeg) {
    v.note = "no videos: ffmpeg is not installed (scripts/setup.sh installs Debian's ffmpeg)";
    std::fprintf(stderr, "restir-sim: %s\n", v.note.c_str());
    return v;
  }
  for (const std::string& p : in.presets) v.perPreset.emplace_back(p, "videos/" + p + ".mp4");
  v.grid = "videos/all_presets.mp4";
  // Each video on a task of its own (ffmpeg runs one encoder thread a video): the same files in any order.
  tbb::parallel_for(size_t{0}, v.perPreset.size() + 1, [&](size_t k) {
    if (k < v.perPreset.size()) WritePresetVideo(in, *ffmpeg, v.perPreset[k].first, v.perPreset[k].second);
    else WriteGridVideo(in, *ffmpeg, v.grid);
  });
  return v;
}

Crops WriteCrops(const MotionInputs& in) {
  Crops c;
  if (in.postRevealFrames.empty()) return c;
  const int w = in.width, h = in.height;
  const std::vector<std::vector<unsigned char>> masks = RevealMasks(in);
  const std::vector<int> count = RevealCounts(masks, static_cast<size_t>(w) * h);
  int x0 = w, y0 = h, x1 = 0, y1 = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (count[y * size_t(w) + x] > 0) x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x + 1),
                                        y1 = std::max(y1, y + 1);
  if (x1 <= x0) return c;
  // The bounding box, grown to at least 1/8 of the frame each way (a few pixels alone say nothing) and, where it
  // is more than a quarter of the frame (or 215 x 160 pixels, so that even a 1080p run's crop is shown at least twice
  // its size), the densest window of that size in it: the enlargement exists to show what a thumbnail cannot.
  const int maxW = std::min(w, std::max(8, std::min(w / 4, 215))), maxH = std::min(h, std::max(8, std::min(h / 4, 160)));
  const int minW = std::min(maxW, std::max(8, w / 8)), minH = std::min(maxH, std::max(8, h / 8));
  c.width = std::clamp(x1 - x0, minW, maxW);
  c.height = std::clamp(y1 - y0, minH, maxH);
  if (x1 - x0 > c.width || y1 - y0 > c.height) {
    DensestWindow(count, w, x0, y0, x1, y1, std::min(c.width, x1 - x0), std::min(c.height, y1 - y0), c.x, c.y);
    c.rule = "the densest window of a quarter of the frame's width and height (at most 215 x 160 pixels) inside the "
             "bounding box of the pixels revealed in the post-reveal frames";
  } else {
    c.x = (x0 + x1) / 2 - c.width / 2;
    c.y = (y0 + y1) / 2 - c.height / 2;
    c.rule = "the bounding box of the pixels revealed in the post-reveal frames";
  }
  c.x = std::clamp(c.x, 0, w - c.width);
  c.y = std::clamp(c.y, 0, h - c.height);
  // Three frames side by side fit the page (about 1300 pixels).
  c.scale = std::max(1, std::min(430 / c.width, 320 / c.height));
  // The reveal frame: the post-reveal frame with the most pixels disoccluded in that frame inside the region; then
  // 2 and 6 frames later (those that exist), to show the recovery.
  int best = -1;
  int reveal = in.postRevealFrames.front();
  for (size_t k = 0; k < masks.size(); ++k) {
    int n = 0;
    for (int y = c.y; y < c.y + c.height; ++y)
      for (int x = c.x; x < c.x + c.width; ++x) n += masks[k][y * size_t(w) + x] == kScrubDisoccludedNow;
    if (n > best) best = n, reveal = in.postRevealFrames[k];
  }
  for (int d : {0, 2, 6})
    if (std::binary_search(in.frames.begin(), in.frames.end(), reveal + d)) c.frames.push_back(reveal + d);
  const std::string dir = "report_images/crops/";  // WriteFileAtomic makes it
  auto write = [&](const std::string& source, const std::string& name) {
    const std::string relative = dir + name + ".png";
    WriteFileAtomic(Path(in, relative), EncodeRgbPng(CropScaled(Read(in, source), w, c), c.width * c.scale,
                                                     c.height * c.scale));
    return relative;
  };
  if (in.hasReference) {
    std::vector<std::string> row;
    for (int f : c.frames) row.push_back(write(ScrubReferencePath(f), "reference_" + FrameNumber(f)));
    c.rows.emplace_back("reference", row);
  }
  for (const std::string& p : in.presets) {
    std::vector<std::string> est, err;
    for (int f : c.frames) {
      est.push_back(write(ScrubPresetPath(p, f, ScrubLayer::kEstimate), p + "_" + FrameNumber(f) + "_estimate"));
      if (in.hasReference) err.push_back(write(ScrubPresetPath(p, f, ScrubLayer::kError), p + "_" + FrameNumber(f) + "_error"));
    }
    c.rows.emplace_back(p, est);
    if (in.hasReference) c.rows.emplace_back(p + " error", err);
  }
  c.present = true;
  return c;
}

void HtmlScrubber(std::ostream& o, const MotionInputs& in) {
  std::vector<std::string> layers = {"estimate"};
  if (in.hasReference) layers.insert(layers.end(), {"reference", "error", "flip"});
  layers.push_back("disocclusion");
  const Json data = {{"frames", in.frames}, {"presets", in.presets}, {"width", in.width}, {"height", in.height},
                     {"fps", in.fps}, {"layers", layers}, {"view", 640}};
  o << "<section id=\"scrubber\" hidden>\n<h2>Frames</h2>\n<div class=\"scrub-controls\" tabindex=\"0\">"
       "<button type=\"button\" id=\"scrub-play\">play</button> <input type=\"range\" id=\"scrub-frame\" min=\"0\" "
       "max=\"0\" value=\"0\" step=\"1\"> <span id=\"scrub-label\"></span> <button type=\"button\" "
       "id=\"scrub-reset\">reset view</button><br>layer:";
  for (const std::string& l : layers)
    o << " <label><input type=\"radio\" name=\"scrub-layer\" value=\"" << l << "\"> " << l << "</label>";
  o << "<br>presets:";
  for (const std::string& p : in.presets)
    o << " <label><input type=\"checkbox\" name=\"scrub-preset\" value=\"" << XmlEscape(p) << "\" checked> "
      << XmlEscape(p) << "</label>";
  o << "</div>\n<div id=\"scrub-panels\"></div>\n<p class=\"note\">Every frame of the run, one exposure throughout. "
       "The wheel zooms and dragging pans, the same view in every panel; ← and → step, space plays. The address "
       "keeps what is shown (#frame=…), so a link shows the same frame. Error: per pixel sqrt(mean over RGB of "
       "(I − R)² / (R² + 0.01)), 0 to ≥ 1; FLIP 0 to 1; disocclusion: white where reprojection failed this frame, "
       "grey where a pixel was revealed in the last 4 frames.</p>\n</section>\n"
       "<noscript><p class=\"note\">The frame scrubber needs JavaScript; the videos, crops and strips below show the "
       "frames without it.</p></noscript>\n<script type=\"application/json\" id=\"scrub-data\">"
    << data.dump() << "</script>\n<script>" << kScrubberScript << "</script>\n";
}

void HtmlVideos(std::ostream& o, const Videos& v) {
  o << "<h2 id=\"videos\">Videos</h2>\n";
  if (!v.note.empty()) {
    o << "<p class=\"note\">" << XmlEscape(v.note) << ".</p>\n";
    return;
  }
  o << "<p class=\"note\">H.264 at the sequence's frame rate (a browser's player can slow it down); each preset: "
       "estimate | reference | error map, one exposure for the whole run; the frame number is in the caption.</p>\n";
  if (!v.grid.empty())
    o << "<p><a href=\"" << XmlEscape(v.grid) << "\">every preset side by side</a></p>\n<video class=\"video\" "
      << "controls loop muted preload=\"metadata\" src=\"" << XmlEscape(v.grid) << "\"></video>\n";
  o << "<ul class=\"videos\">\n";
  for (const auto& [preset, path] : v.perPreset)
    o << "<li><a href=\"" << XmlEscape(path) << "\">" << XmlEscape(preset) << "</a></li>\n";
  o << "</ul>\n";
}

void HtmlCrops(std::ostream& o, const Crops& c) {
  o << "<h2 id=\"crops\">What was revealed, enlarged</h2>\n";
  if (!c.present) {
    o << "<p class=\"note\">No frame revealed anything (no disocclusion), or no frames were written: no crops.</p>\n";
    return;
  }
  o << "<p class=\"note\">Pixels " << c.x << "–" << c.x + c.width - 1 << " × " << c.y << "–" << c.y + c.height - 1
    << " of the frame (" << XmlEscape(c.rule) << "), each shown as " << c.scale << "×" << c.scale
    << ". First column: the frame with the most pixels disoccluded in that region; then the frames after it.</p>\n";
  o << "<table class=\"strip crops\">\n<tr><th></th>";
  for (int f : c.frames) o << "<th>frame " << f << "</th>";
  o << "</tr>\n";
  for (const auto& [name, paths] : c.rows) {
    o << "<tr><td>" << XmlEscape(name) << "</td>";
    for (size_t k = 0; k < paths.size(); ++k)
      o << "<td><img class=\"crop\" src=\"" << XmlEscape(paths[k]) << "\" alt=\"" << XmlEscape(name) << " frame "
        << c.frames[k] << " crop\" width=\"" << c.width * c.scale << "\" height=\"" << c.height * c.scale
        << "\"></td>";
    o << "</tr>\n";
  }
  o << "</table>\n";
}

Json VideosJson(const Videos& v) {
  Json presets = Json::object();
  for (const auto& [preset, path] : v.perPreset) presets[preset] = path;
  return {{"per_preset", presets},
          {"all_presets", v.grid.empty() ? Json(nullptr) : Json(v.grid)},
          {"note", v.note.empty() ? Json(nullptr) : Json(v.note)}};
}

Json CropsJson(const Crops& c) {
  if (!c.present) return nullptr;
  return {{"x", c.x}, {"y", c.y}, {"width", c.width}, {"height", c.height}, {"scale", c.scale},
          {"frames", c.frames}, {"rule", c.rule}};
}

}  // namespace restir
