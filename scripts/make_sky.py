#!/usr/bin/env python3
"""Write a clear-sky environment map as a Radiance .hdr (RGBE), python3 standard library only.

  make_sky.py [OUT] [--width W] [--height H]   (default data/sky/clear_sky.hdr, 128 x 64)

The map is equirectangular in the layout the sequence format reads (docs/sequence-format.md, "Environment"):
row 0 at the top (+Y, the zenith), the last row at the nadir, column 0 at longitude +pi, longitude =
atan2(x, z). The sky depends on elevation only, so the columns are equal and the longitude convention does not
matter here: a sun can be put anywhere with the sequence's "sun" without disagreeing with the map.

Linear RGB radiance, normalised so that the horizon's luminance is about 1 (scale it with the environment's
"intensity"):
  - above the horizon a gradient from a white haze at the horizon to a deeper blue at the zenith
    (mix = exp(-sin(elevation) / 0.35): most of the change within the lowest 30 degrees, as in a clear sky);
  - below it a dim brownish ground (luminance about 0.15), meeting the haze over the first 2 degrees.
Every texel holds the value at its centre. Uncompressed ("flat") scanlines: readers tell them from run-length
encoded ones by their first pixel, and a flat pixel never starts like an RLE scanline (2, 2, b < 128): a pixel's
largest component has a mantissa of at least 128, so one whose red and green are 2 has a blue of 128 or more.
"""

import argparse
import math
import os
import struct

ZENITH = (0.18, 0.33, 0.80)   # luminance ~ 0.33: the deep blue overhead
HORIZON = (0.96, 0.98, 1.04)  # luminance ~ 0.98: white haze
GROUND = (0.16, 0.15, 0.14)   # luminance ~ 0.15: dim ground below the horizon


def sky_radiance(elevation):
    """Linear RGB radiance of the sky at an elevation (radians, positive above the horizon)."""
    if elevation >= 0.0:
        m = math.exp(-math.sin(elevation) / 0.35)  # 1 at the horizon, 0.24 at 30 degrees, 0.06 at the zenith
        return tuple(z * (1.0 - m) + h * m for z, h in zip(ZENITH, HORIZON))
    t = min(1.0, -elevation / math.radians(2.0))  # haze fading into the ground over 2 degrees
    t = t * t * (3.0 - 2.0 * t)
    return tuple(h * (1.0 - t) + g * t for h, g in zip(HORIZON, GROUND))


def rgbe(rgb):
    """Ward's RGBE encoding of one linear RGB value (as Radiance's float2rgbe)."""
    v = max(rgb)
    if v < 1e-32:
        return b"\0\0\0\0"
    mantissa, exponent = math.frexp(v)  # v = mantissa * 2^exponent, mantissa in [0.5, 1)
    scale = mantissa * 256.0 / v
    return bytes([int(c * scale) for c in rgb] + [exponent + 128])


def write_hdr(path, width, height):
    rows = []
    for r in range(height):
        elevation = math.pi / 2 - math.pi * (r + 0.5) / height  # texel centre: +pi/2 at the top
        pixel = rgbe(sky_radiance(elevation))
        rows.append(pixel * width)
    header = b"#?RADIANCE\n# clear sky, scripts/make_sky.py\nFORMAT=32-bit_rle_rgbe\n\n"
    header += b"-Y %d +X %d\n" % (height, width)
    data = header + b"".join(rows)
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(data)
    os.replace(tmp, path)
    return len(data)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out", nargs="?", default=os.path.join(here, "..", "data", "sky", "clear_sky.hdr"))
    parser.add_argument("--width", type=int, default=128)
    parser.add_argument("--height", type=int, default=64)
    args = parser.parse_args()
    if not (8 <= args.width <= 32767 and 2 <= args.height <= 32767):
        parser.error("width must be in [8, 32767] and height in [2, 32767]")
    size = write_hdr(args.out, args.width, args.height)
    print("wrote %s: %d x %d, %d bytes" % (os.path.normpath(args.out), args.width, args.height, size))


if __name__ == "__main__":
    main()
