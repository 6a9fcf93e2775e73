#!/usr/bin/env python3
"""Writes the glTF 2.0 assets the project makes itself (docs/sequence-format.md "Assets").

  make_assets.py lamp-panel DIR   data/assets/lamp_panel.gltf + lamp_panel_emission.png: a ceiling panel of
                                  32 x 24 small square lamps (1,536 emissive triangles), each lamp's colour from
                                  one cell of an emissive texture, strength by KHR_materials_emissive_strength.
                                  sequences/asset_table.json hangs it over a table of third-party assets.
  make_assets.py lamp-strip DIR   data/assets/lamp_strip.gltf + lamp_strip_emission.png: the same panel with 8 x 3
                                  larger lamps (48 emissive triangles); sequences/sun_street_pan.json lights its
                                  cafe with it (a reference's per-pixel light choice costs per emitter triangle).
  make_assets.py scale DIR [--triangles N] [--emitters M]
                                  DIR/scale.glb and DIR/scale.json: the load-and-run test of issue 17 (default
                                  1,000,000 scene triangles in a rippled floor and 100,000 emissive triangles in
                                  a ceiling of tiny lamps). Not shipped: generated where it is measured.

Only the standard library: the buffers are packed with struct, the PNG with zlib, so the files are reproducible
byte for byte from this script.
"""
import argparse
import base64
import json
import math
import os
import struct
import sys
import zlib


def png_bytes(width, height, rgb_rows):
    """An 8-bit RGB PNG (sRGB-encoded values, as glTF colour textures are)."""
    raw = b"".join(b"\x00" + bytes(row) for row in rgb_rows)

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


class Gltf:
    """Accumulates meshes into one binary buffer."""

    def __init__(self):
        self.buffer = bytearray()
        self.doc = {"asset": {"version": "2.0", "generator": "restir-sim scripts/make_assets.py"},
                    "scene": 0, "scenes": [{"nodes": []}], "nodes": [], "meshes": [], "materials": [],
                    "accessors": [], "bufferViews": [], "buffers": []}

    def _view(self, data, target):
        while len(self.buffer) % 4:
            self.buffer.append(0)
        self.doc["bufferViews"].append({"buffer": 0, "byteOffset": len(self.buffer), "byteLength": len(data),
                                        "target": target})
        self.buffer += data
        return len(self.doc["bufferViews"]) - 1

    def _accessor(self, view, component, count, kind, lo=None, hi=None):
        a = {"bufferView": view, "componentType": component, "count": count, "type": kind}
        if lo is not None:
            a["min"], a["max"] = lo, hi
        self.doc["accessors"].append(a)
        return len(self.doc["accessors"]) - 1

    def material(self, m):
        self.doc["materials"].append(m)
        return len(self.doc["materials"]) - 1

    def mesh(self, name, positions, triangles, material, uvs=None, translation=None):
        pos = struct.pack("<%df" % (3 * len(positions)), *[c for p in positions for c in p])
        lo = [min(p[k] for p in positions) for k in range(3)]
        hi = [max(p[k] for p in positions) for k in range(3)]
        attributes = {"POSITION": self._accessor(self._view(pos, 34962), 5126, len(positions), "VEC3", lo, hi)}
        if uvs is not None:
            uv = struct.pack("<%df" % (2 * len(uvs)), *[c for t in uvs for c in t])
            attributes["TEXCOORD_0"] = self._accessor(self._view(uv, 34962), 5126, len(uvs), "VEC2")
        idx = struct.pack("<%dI" % (3 * len(triangles)), *[i for t in triangles for i in t])
        indices = self._accessor(self._view(idx, 34963), 5125, 3 * len(triangles), "SCALAR")
        self.doc["meshes"].append({"name": name, "primitives": [{"attributes": attributes, "indices": indices,
                                                                  "material": material}]})
        node = {"name": name, "mesh": len(self.doc["meshes"]) - 1}
        if translation:
            node["translation"] = translation
        self.doc["nodes"].append(node)
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]) - 1)

    def write_gltf(self, path):
        """A .gltf with its buffer inline (base64 data URI): one self-contained text file."""
        self.doc["buffers"] = [{"byteLength": len(self.buffer),
                                "uri": "data:application/octet-stream;base64," + base64.b64encode(self.buffer).decode()}]
        write_atomic(path, (json.dumps(self.doc, indent=1) + "\n").encode())

    def write_glb(self, path):
        self.doc["buffers"] = [{"byteLength": len(self.buffer)}]
        js = json.dumps(self.doc, separators=(",", ":")).encode()
        js += b" " * (-len(js) % 4)
        binary = bytes(self.buffer) + b"\x00" * (-len(self.buffer) % 4)
        body = (struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(binary), b"BIN\x00") + binary)
        write_atomic(path, struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)


def write_atomic(path, data):
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(data)
    os.replace(tmp, path)


def lamp_panel(out, name="lamp_panel", nx=32, nz=24, size=0.035, pitch=0.06):
    g = Gltf()
    # The emissive texture: one texel per lamp, warm to cool across the panel, dimmer towards its edges.
    rows = []
    for j in range(nz):
        row = []
        for i in range(nx):
            t = i / (nx - 1)
            edge = 0.55 + 0.45 * math.sin(math.pi * (j + 0.5) / nz)
            warm, cool = (255, 196, 140), (170, 205, 255)
            row += [round((warm[c] * (1 - t) + cool[c] * t) * edge) for c in range(3)]
        rows.append(row)
    write_atomic(os.path.join(out, name + "_emission.png"), png_bytes(nx, nz, rows))
    g.doc["images"] = [{"uri": name + "_emission.png"}]
    g.doc["samplers"] = [{"magFilter": 9728, "minFilter": 9728}]
    g.doc["textures"] = [{"source": 0, "sampler": 0}]
    g.doc["extensionsUsed"] = ["KHR_materials_emissive_strength"]
    lamp = g.material({"name": "lamp", "emissiveFactor": [1.0, 1.0, 1.0], "emissiveTexture": {"index": 0},
                       "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0},
                       "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 60.0}}})
    positions, uvs, tris = [], [], []
    x0, z0 = -0.5 * (nx - 1) * pitch, -0.5 * (nz - 1) * pitch
    for j in range(nz):
        for i in range(nx):
            cx, cz = x0 + i * pitch, z0 + j * pitch
            # The cell's centre in texture space (v up, as glTF's v down flipped): every corner samples its lamp's
            # texel, so each triangle's mean is exactly that texel.
            u, v = (i + 0.5) / nx, (j + 0.5) / nz
            b = len(positions)
            h = 0.5 * size
            positions += [(cx - h, 0.0, cz - h), (cx + h, 0.0, cz - h), (cx + h, 0.0, cz + h), (cx - h, 0.0, cz + h)]
            uvs += [(u, v)] * 4
            # Facing down (-y): counter-clockwise seen from below.
            tris += [(b, b + 1, b + 2), (b, b + 2, b + 3)]
    g.mesh("lamps", positions, tris, lamp, uvs)
    g.write_gltf(os.path.join(out, name + ".gltf"))
    print("wrote %s: %d emissive triangles" % (os.path.join(out, name + ".gltf"), len(tris)))


def scale(out, triangles, emitters):
    g = Gltf()
    floor = g.material({"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1],
                                                                  "metallicFactor": 0.0, "roughnessFactor": 0.8}})
    lamp = g.material({"name": "lamp", "emissiveFactor": [1.0, 0.9, 0.8],
                       "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0}})
    # A rippled floor of n x n quads, 2 triangles each.
    n = max(1, math.ceil(math.sqrt(triangles / 2)))
    positions, tris = [], []
    for j in range(n + 1):
        for i in range(n + 1):
            x, z = -5 + 10 * i / n, -5 + 10 * j / n
            positions.append((x, 0.02 * math.sin(7 * x) * math.cos(5 * z), z))
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            tris += [(a, a + n + 1, a + 1), (a + 1, a + n + 1, a + n + 2)]  # facing +y
    g.mesh("floor", positions, tris, floor)
    # A ceiling of m x m tiny lamps, facing down, each a separate triangle pair.
    m = max(1, math.ceil(math.sqrt(emitters / 2)))
    positions, lamps = [], []
    for j in range(m):
        for i in range(m):
            cx, cz, h = -4.5 + 9 * (i + 0.5) / m, -4.5 + 9 * (j + 0.5) / m, 9 / m * 0.3
            b = len(positions)
            positions += [(cx - h, 3.0, cz - h), (cx + h, 3.0, cz - h), (cx + h, 3.0, cz + h), (cx - h, 3.0, cz + h)]
            lamps += [(b, b + 1, b + 2), (b, b + 2, b + 3)]
    g.mesh("lamps", positions, lamps, lamp)
    glb = os.path.join(out, "scale.glb")
    g.write_glb(glb)
    seq = {"name": "scale", "description": "issue 17's load-and-run test: %d scene and %d emissive triangles" %
           (len(tris), len(lamps)), "resolution": [640, 360], "frames": 4,
           "materials": [], "objects": [{"name": "scene", "asset": {"file": "scale.glb", "emissionScale": 40}}],
           "lights": [], "camera": {"keyframes": [{"frame": 0, "position": [-3, 1.6, 4], "lookAt": [0, 0.3, 0], "fov": 60},
                                                  {"frame": 3, "position": [-2.8, 1.6, 4], "lookAt": [0.2, 0.3, 0], "fov": 60}]},
           "render": {"presets": ["ris"], "referenceSpp": 32}}
    write_atomic(os.path.join(out, "scale.json"), (json.dumps(seq, indent=1) + "\n").encode())
    print("wrote %s: %d scene triangles, %d emissive triangles" % (glb, len(tris), len(lamps)))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="what", required=True)
    a = sub.add_parser("lamp-panel")
    a.add_argument("dir")
    a2 = sub.add_parser("lamp-strip")
    a2.add_argument("dir")
    b = sub.add_parser("scale")
    b.add_argument("dir")
    b.add_argument("--triangles", type=int, default=1_000_000)
    b.add_argument("--emitters", type=int, default=100_000)
    args = p.parse_args()
    os.makedirs(args.dir, exist_ok=True)
    if args.what == "lamp-panel":
        lamp_panel(args.dir)
    elif args.what == "lamp-strip":
        lamp_panel(args.dir, "lamp_strip", nx=8, nz=3, size=0.12, pitch=0.2)
    else:
        scale(args.dir, args.triangles, args.emitters)


if __name__ == "__main__":
    sys.exit(main())
