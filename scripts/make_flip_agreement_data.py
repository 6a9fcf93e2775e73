#!/usr/bin/env python3
"""Image pairs for checking sim/metrics/flip.h against NVIDIA's FLIP (tests/data/flip_nvidia/), and NVIDIA's results on them.

  make_flip_agreement_data.py images [--out DIR] [--restir-sim BIN]
  make_flip_agreement_data.py nvidia --flip-tool FLIP --map-tool MAP --commit HASH [--out DIR]

`images` writes the pairs (python3 standard library; `oiiotool` and the built `restir-sim` for the two render
crops). LDR pairs are 8-bit sRGB-encoded PNGs (LDR-FLIP after the sRGB decode), HDR pairs linear half-float EXRs
(HDR-FLIP). The synthetic images come from a fixed seed, so rerunning gives the same files; the render crops
come from `restir-sim run sequences/window_bars_pan.json` at 320x180, deterministic too, but only for one build
of the renderer, so a later renderer may crop different pixels: the stored files are the data, not this script.

`nvidia` runs NVIDIA's FLIP on every pair and writes pairs.json with its means and its float error maps
(NAME.nvidia.exr). Build both tools from a checkout of https://github.com/NVlabs/flip, outside this repository
(none of its code or images is kept here; only its outputs are, as test data):
  g++ -O2 -std=c++17 -o flip FLIP/src/cpp/tool/FLIP-tool.cpp                          # NVIDIA's tool, CPU
  g++ -O2 -std=c++17 -I FLIP/src/cpp -o flip_nvidia_map scripts/flip_nvidia_map.cpp  # its float map
The tool prints the mean to 6 decimals and saves its map as an 8-bit PNG only, so the map comes from
scripts/flip_nvidia_map.cpp, which calls the same FLIP::evaluate the tool does; this script checks that the two
agree (the same printed mean, byte-identical grayscale PNGs of the map).
"""

import argparse
import json
import math
import os
import random
import struct
import subprocess
import tempfile
import zlib

# ---------------------------------------------------------------------------------------------------------------
# Writers

def write_png(path, width, height, pixels):
    """pixels: rows of (r, g, b) in [0, 1], sRGB-encoded; stored as 8 bits, rounded."""
    raw = bytearray()
    for y in range(height):
        raw.append(0)  # filter: none
        for x in range(width):
            for c in pixels[y * width + x]:
                raw.append(max(0, min(255, int(round(c * 255.0)))))

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(bytes(raw), 9)))
        f.write(chunk(b"IEND", b""))


def read_uncompressed_exr(path):
    """(width, height, pixels) of a single-part scanline EXR without compression whose channels are B, G, R
    (FLOAT), as oiiotool writes the render crops; rewritten by write_exr so that no file metadata (oiiotool's
    date and command line) gets into the data."""
    with open(path, "rb") as f:
        data = f.read()
    pos, attrs = 8, {}
    while data[pos] != 0:
        name_end = data.index(b"\0", pos)
        kind_end = data.index(b"\0", name_end + 1)
        size = struct.unpack_from("<i", data, kind_end + 1)[0]
        attrs[data[pos:name_end].decode()] = data[kind_end + 5:kind_end + 5 + size]
        pos = kind_end + 5 + size
    pos += 1
    if attrs["compression"] != b"\0" or not attrs["channels"].startswith(b"B\0\x02\0\0\0"):
        raise SystemExit("%s: expected uncompressed FLOAT B, G, R" % path)
    x0, y0, x1, y1 = struct.unpack("<iiii", attrs["dataWindow"])
    w, h = x1 - x0 + 1, y1 - y0 + 1
    pixels = [None] * (w * h)
    for y in range(h):
        offset = struct.unpack_from("<Q", data, pos + 8 * y)[0]
        line_y, size = struct.unpack_from("<ii", data, offset)
        b, g, r = (struct.unpack_from("<%df" % w, data, offset + 8 + 4 * w * c) for c in range(3))
        for x in range(w):
            pixels[(line_y - y0) * w + x] = (r[x], g[x], b[x])
    return w, h, pixels


def _exr_zip(raw):
    # OpenEXR's ZIP block: bytes split into even and odd halves, then a byte-wise delta predictor, then zlib.
    t = bytearray(raw[0::2] + raw[1::2])
    p = t[0] if t else 0
    for i in range(1, len(t)):
        d = (t[i] - p + 384) & 0xFF
        p = t[i]
        t[i] = d
    packed = zlib.compress(bytes(t), 9)
    return packed if len(packed) < len(raw) else bytes(raw)  # readers take an uncompressed-size block as raw


def write_exr(path, width, height, pixels):
    """pixels: linear (r, g, b); stored as HALF channels B, G, R, ZIP compression (16 scanlines a block)."""
    def attr(name, kind, value):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value

    chlist = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", 1, 0, 1, 1) for c in "BGR") + b"\0"
    box = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    header = (b"\x76\x2f\x31\x01" + struct.pack("<i", 2) + attr("channels", "chlist", chlist) +
              attr("compression", "compression", b"\x03") + attr("dataWindow", "box2i", box) +
              attr("displayWindow", "box2i", box) + attr("lineOrder", "lineOrder", b"\x00") +
              attr("pixelAspectRatio", "float", struct.pack("<f", 1.0)) +
              attr("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0)) +
              attr("screenWindowWidth", "float", struct.pack("<f", 1.0)) + b"\0")
    chunks = []
    for y0 in range(0, height, 16):
        raw = bytearray()
        for y in range(y0, min(y0 + 16, height)):
            row = pixels[y * width:(y + 1) * width]
            for c in (2, 1, 0):
                raw += struct.pack("<%de" % width, *(p[c] for p in row))
        data = _exr_zip(raw)
        chunks.append(struct.pack("<ii", y0, len(data)) + data)
    offset = len(header) + 8 * len(chunks)
    table = b""
    for c in chunks:
        table += struct.pack("<Q", offset)
        offset += len(c)
    with open(path, "wb") as f:
        f.write(header + table + b"".join(chunks))


# ---------------------------------------------------------------------------------------------------------------
# Synthetic pairs. Each returns (reference, test) as lists of (r, g, b): sRGB-encoded in [0, 1] for LDR, linear
# radiance for HDR.

def clamp01(v):
    return max(0.0, min(1.0, v))


def ldr_gradient(w, h, rng):
    ref = [(x / (w - 1), y / (h - 1), 0.5 + 0.5 * math.sin(0.15 * (x + y))) for y in range(h) for x in range(w)]
    test = [tuple(round(c * 7.0) / 7.0 for c in p) for p in ref]  # banding
    return ref, test


def ldr_noise(w, h, rng):
    ref = [(0.5 + 0.3 * math.sin(0.2 * x) * math.cos(0.17 * y),) * 3 for y in range(h) for x in range(w)]
    test = [tuple(clamp01(c + rng.uniform(-0.12, 0.12)) for c in p) for p in ref]
    return ref, test


def _lines(w, h, shift, missing):
    img = []
    for y in range(h):
        for x in range(w):
            v = 0.8 if (x // 12 + y // 12) % 2 == 0 else 0.2       # blocks: edges
            if (x + shift) % 16 == 5:
                v = 1.0                                            # one-pixel vertical lines
            if y % 20 == 9 and not (missing and y > h // 2):
                v = 0.0                                            # one-pixel horizontal lines
            img.append((v, v, v))
    return img


def ldr_edges(w, h, rng):
    ref = _lines(w, h, 0, False)
    test = _lines(w, h, 1, True)
    return ref, test


PATCH_COLOURS = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (0, 1, 1), (1, 0, 1), (1, 1, 0)]


def _patches(w, h, transform):
    img = []
    for y in range(h):
        for x in range(w):
            i = (x * 3 // w) + 3 * (y * 2 // h)
            inside = (x % (w // 3)) > 4 and (y % (h // 2)) > 4
            img.append(transform(PATCH_COLOURS[i]) if inside else (0.5, 0.5, 0.5))
    return img


def ldr_color(w, h, rng):
    ref = _patches(w, h, lambda c: tuple(0.1 + 0.8 * v for v in c))
    test = _patches(w, h, lambda c: (0.1 + 0.8 * c[1], 0.1 + 0.8 * c[2], 0.1 + 0.6 * c[0]))  # hue rotated
    return ref, test


def _disk(x, y, cx, cy, r):
    return (x - cx) ** 2 + (y - cy) ** 2 < r * r


def ldr_odd(w, h, rng):
    ref, test = [], []
    for y in range(h):
        for x in range(w):
            base = 0.2 + 0.6 * x / (w - 1)
            ref.append((0.9, 0.7, 0.2) if _disk(x, y, 30, 22, 12) else (base, base, 0.3))
            t = (0.9, 0.7, 0.2) if _disk(x, y, 32, 21, 12) else (base, base, 0.3)
            test.append(tuple(clamp01(c + rng.uniform(-0.05, 0.05)) for c in t))
    return ref, test


def ldr_dark(w, h, rng):
    ref, test = [], []
    for y in range(h):
        for x in range(w):
            v = 0.15 if _disk(x, y, 20, 20, 6) or (x == 50 and y > 10) else 0.0
            ref.append((v, v, v))
            n = rng.random()
            test.append((v, v, v) if n < 0.9 else (0.06, 0.05, 0.08))
    return ref, test


def hdr_range(w, h, rng):
    # 1e-3 to 1e3 across the width; the tint changes down the height.
    ref = []
    for y in range(h):
        for x in range(w):
            v = 10.0 ** (-3.0 + 6.0 * x / (w - 1))
            t = y / (h - 1)
            ref.append((v * (0.6 + 0.4 * t), v, v * (1.0 - 0.5 * t)))
    test = [tuple(max(0.0, c * (1.0 + 0.3 * rng.gauss(0.0, 1.0))) for c in p) for p in ref]
    return ref, test


def hdr_noise(w, h, rng):
    # Smooth lighting between about 0.1 and 10, and Monte Carlo-like noise: each pixel scaled by an exponential
    # variate of mean 1 (a few fireflies), colour by colour.
    ref = []
    for y in range(h):
        for x in range(w):
            v = 10.0 ** (math.sin(0.09 * x) * math.cos(0.11 * y))
            ref.append((v, 0.8 * v, 0.6 * v))
    test = [tuple(c * -math.log(1.0 - rng.random()) for c in p) for p in ref]
    return ref, test


def _hdr_lines(w, h, shift, soft):
    img = []
    for y in range(h):
        for x in range(w):
            v = 0.01 + 0.09 * x / (w - 1)
            inside = 20 <= x < 60 and 15 <= y < 45
            if inside:
                v = 5.0
            elif soft and (19 <= x < 61 and 14 <= y < 46):
                v = 2.5                                     # a blurred box edge
            if (x + shift) % 24 == 3:
                v = 50.0                                    # bright one-pixel lines
            img.append((v, v * 0.9, v * 0.8))
    return img


def hdr_edges(w, h, rng):
    return _hdr_lines(w, h, 0, False), _hdr_lines(w, h, 1, True)


def hdr_color(w, h, rng):
    # The six saturated patches at 0.01, 0.1, ..., 1000; the test's hues rotated and dimmed in one channel.
    ref = _patches(w, h, lambda c: tuple(0.02 + v for v in c))
    level = [10.0 ** (((x * 3 // w) + 3 * (y * 2 // h)) - 2) for y in range(h) for x in range(w)]
    ref = [tuple(c * s for c in p) for p, s in zip(ref, level)]
    test = [(p[1], p[2], p[0] * 0.7) for p in ref]
    return ref, test


def hdr_dark(w, h, rng):
    # Mostly dark: 40% of the pixels exactly 0 (fewer than half, where NVIDIA's FLIP and ours choose the same
    # exposures; see docs/metrics.md), the rest dim, and a few fireflies.
    ref, test = [], []
    for y in range(h):
        for x in range(w):
            if (x * 5 // w) < 2:
                v = (0.0, 0.0, 0.0)
            else:
                d = 10.0 ** (-3.0 + 1.0 * y / (h - 1))
                v = (d, d, d)
                if rng.random() < 0.01:
                    v = (100.0, 90.0, 80.0)
            ref.append(v)
            noisy = tuple(c * -math.log(1.0 - rng.random()) for c in v)
            if v[0] == 0.0 and rng.random() < 0.05:
                noisy = (0.02, 0.02, 0.02)
            test.append(noisy)
    return ref, test


def hdr_odd(w, h, rng):
    ref, test = [], []
    for y in range(h):
        for x in range(w):
            v = 10.0 ** (-3.0 + 6.0 * ((x + y) % 23) / 22.0)
            c = (v, v * 0.5, v * 0.25) if _disk(x, y, 33, 22, 15) else (v * 0.25, v * 0.5, v)
            ref.append(c)
            test.append(tuple(max(0.0, k * (1.0 + 0.5 * rng.gauss(0.0, 1.0))) for k in c))
    return ref, test


# name, mode, width, height, generator
SYNTHETIC = [
    ("ldr_gradient", "ldr", 96, 64, ldr_gradient),
    ("ldr_noise", "ldr", 80, 64, ldr_noise),
    ("ldr_edges", "ldr", 96, 64, ldr_edges),
    ("ldr_color", "ldr", 96, 64, ldr_color),
    ("ldr_odd", "ldr", 67, 45, ldr_odd),
    ("ldr_dark", "ldr", 64, 48, ldr_dark),
    ("hdr_range", "hdr", 96, 64, hdr_range),
    ("hdr_noise", "hdr", 80, 64, hdr_noise),
    ("hdr_edges", "hdr", 96, 64, hdr_edges),
    ("hdr_color", "hdr", 96, 64, hdr_color),
    ("hdr_dark", "hdr", 64, 48, hdr_dark),
    ("hdr_odd", "hdr", 67, 45, hdr_odd),
]

# Crops of window_bars_pan frame 1 at 320x180: name, preset, WxH+X+Y.
RENDER_CROPS = [
    ("hdr_render_bars", "restir-unbiased", "112x80+104+30"),
    ("hdr_render_ris", "ris", "96x64+200+100"),
]


def make_images(out, restir_sim):
    os.makedirs(out, exist_ok=True)
    pairs = []
    for seed, (name, mode, w, h, gen) in enumerate(SYNTHETIC):
        ref, test = gen(w, h, random.Random(1000 + seed))
        ext = "png" if mode == "ldr" else "exr"
        write = write_png if mode == "ldr" else write_exr
        write(os.path.join(out, "%s.ref.%s" % (name, ext)), w, h, ref)
        write(os.path.join(out, "%s.test.%s" % (name, ext)), w, h, test)
        pairs.append({"name": name, "mode": mode})
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([restir_sim, "run", "sequences/window_bars_pan.json", "--frames", "1:2", "--resolution",
                        "320x180", "--reference-spp", "256", "--preset", "ris,restir-unbiased", "--cache-dir", "",
                        "--no-progress", "--no-report", "-o", tmp], check=True)
        for name, preset, cut in RENDER_CROPS:
            frame = os.path.join(tmp, "frames", preset, "0001.exr")
            for role, channels in (("ref", "reference.R,reference.G,reference.B"), ("test", "R,G,B")):
                crop = os.path.join(tmp, "crop.exr")
                subprocess.run(["oiiotool", frame, "--ch", channels, "--chnames", "R,G,B", "--cut", cut, "--origin",
                                "+0+0", "--fullpixels", "-d", "float", "--compression", "none", "-o", crop],
                               check=True)
                write_exr(os.path.join(out, "%s.%s.exr" % (name, role)), *read_uncompressed_exr(crop))
            pairs.append({"name": name, "mode": "hdr"})
    return pairs


# ---------------------------------------------------------------------------------------------------------------
# NVIDIA's results

def run_nvidia(out, flip_tool, map_tool, commit):
    names = sorted({f.split(".")[0] for f in os.listdir(out) if ".ref." in f})
    order = [n for n, *_ in SYNTHETIC] + [n for n, *_ in RENDER_CROPS]
    names = [n for n in order if n in names]
    pairs = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            ext = "png" if name.startswith("ldr") else "exr"
            ref, test = "%s.ref.%s" % (name, ext), "%s.test.%s" % (name, ext)
            tool = subprocess.run([flip_tool, "-r", ref, "-t", test, "-v", "2", "-nm", "-nexm", "-d", tmp, "-b",
                                   name], cwd=out, check=True, capture_output=True, text=True).stdout
            tool_mean = next(float(l.split(":")[1]) for l in tool.splitlines() if l.strip().startswith("Mean:"))
            exr = os.path.join(out, "%s.nvidia.exr" % name)
            res = dict(l.split() for l in subprocess.run([map_tool, os.path.join(out, ref), os.path.join(out, test),
                                                          exr], check=True, capture_output=True, text=True)
                       .stdout.splitlines())
            driver_png = exr[:-4] + ".png"
            with open(driver_png, "rb") as a, open(os.path.join(tmp, name + ".png"), "rb") as b:
                if a.read() != b.read():
                    raise SystemExit("%s: the map tool's map differs from NVIDIA's tool's" % name)
            os.remove(driver_png)
            if "%.6f" % float(res["mean_float"]) != "%.6f" % tool_mean:
                raise SystemExit("%s: the map tool's mean %s is not the tool's %.6f" % (name, res["mean_float"],
                                                                                       tool_mean))
            entry = {"name": name, "mode": "ldr" if ext == "png" else "hdr", "reference": ref, "test": test,
                     "nvidia_map": os.path.basename(exr), "nvidia_tool_mean": "%.6f" % tool_mean,
                     "nvidia_map_mean": float(res["mean_double"])}
            if ext == "exr":
                entry["nvidia_exposures"] = {"start": float(res["start"]), "stop": float(res["stop"]),
                                             "count": int(res["count"])}
            pairs.append(entry)
    doc = {
        "about": "Pairs for tests/sim/metrics/flip_nvidia_test.cpp, made by scripts/make_flip_agreement_data.py. "
                 "nvidia_tool_mean is what NVIDIA's tool printed (6 decimals); nvidia_map is its float error map, "
                 "from scripts/flip_nvidia_map.cpp (the same FLIP::evaluate call), and nvidia_map_mean that "
                 "map's mean summed in double.",
        "nvidia_flip": {"repository": "https://github.com/NVlabs/flip", "commit": commit, "version": "1.6",
                        "build": "g++ 12.2 -O2 -std=c++17 src/cpp/tool/FLIP-tool.cpp (CPU, no OpenMP)",
                        "command": "flip -r NAME.ref.EXT -t NAME.test.EXT -v 2 -nm -nexm -d DIR -b NAME",
                        "map_command": "flip_nvidia_map NAME.ref.EXT NAME.test.EXT NAME.nvidia.exr",
                        "parameters": "defaults: 67.02 ppd (0.7 m, 0.7 m, 3840 px), ACES, exposures from the "
                                      "reference; PNG = LDR-FLIP after the sRGB decode, EXR = HDR-FLIP"},
        "pairs": pairs,
    }
    with open(os.path.join(out, "pairs.json"), "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    return pairs


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("step", choices=["images", "nvidia"])
    ap.add_argument("--out", default="tests/data/flip_nvidia")
    ap.add_argument("--restir-sim", default="build/release/restir-sim")
    ap.add_argument("--flip-tool")
    ap.add_argument("--map-tool")
    ap.add_argument("--commit")
    a = ap.parse_args()
    if a.step == "images":
        make_images(a.out, a.restir_sim)
    else:
        if not (a.flip_tool and a.map_tool and a.commit):
            ap.error("nvidia needs --flip-tool, --map-tool and --commit")
        for p in run_nvidia(a.out, os.path.abspath(a.flip_tool), os.path.abspath(a.map_tool), a.commit):
            print(p["name"], p["nvidia_tool_mean"], p["nvidia_map_mean"])


if __name__ == "__main__":
    main()
