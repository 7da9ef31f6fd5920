#!/usr/bin/env python3
"""Writes the tiny stand-in files (images, meshes, spectra) that the stand-in scenes name.

The public scenes name large textures, environment maps and meshes; the stand-ins name these
small files instead (2 x 2 images, a 4-triangle PLY), written here with the standard library
only, so that `lensim check` finds every file it must find. Run from anywhere:
    python3 tests/data/public-scenes/make_assets.py
"""
import gzip
import os
import struct
import zlib

ROOT = os.path.dirname(os.path.abspath(__file__))
W = H = 2
RGB = [(0.8, 0.2, 0.1), (0.1, 0.7, 0.2), (0.2, 0.3, 0.9), (0.5, 0.5, 0.5)]


def out(rel):
    path = os.path.join(ROOT, rel)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    return path


def png(rel, channels=3):
    rows = b""
    for y in range(H):
        rows += b"\x00"
        for x in range(W):
            c = RGB[y * W + x]
            px = [int(v * 255) for v in c][:channels] if channels >= 3 else [int(c[0] * 255)]
            if channels == 4:
                px = [int(v * 255) for v in c] + [255 if x == 0 else 0]
            rows += bytes(px)

    def chunk(tag, data):
        return (struct.pack(">I", len(data)) + tag + data +
                struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF))

    colour_type = {1: 0, 3: 2, 4: 6}[channels]
    data = (b"\x89PNG\r\n\x1a\n" +
            chunk(b"IHDR", struct.pack(">IIBBBBB", W, H, 8, colour_type, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))
    open(out(rel), "wb").write(data)



def pfm(rel):
    body = b""
    for y in reversed(range(H)):  # PFM rows run bottom to top
        for x in range(W):
            body += struct.pack("<3f", *RGB[y * W + x])
    open(out(rel), "wb").write(b"PF\n%d %d\n-1.0\n" % (W, H) + body)


def exr(rel):
    # Uncompressed scanline OpenEXR, FLOAT channels B, G, R (alphabetical, as the format requires).
    def attr(name, typ, value):
        return name.encode() + b"\0" + typ.encode() + b"\0" + struct.pack("<i", len(value)) + value

    chlist = b"".join(c + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in (b"B", b"G", b"R"))
    chlist += b"\0"
    header = (b"\x76\x2f\x31\x01" + struct.pack("<i", 2) +
              attr("channels", "chlist", chlist) +
              attr("compression", "compression", b"\0") +
              attr("dataWindow", "box2i", struct.pack("<4i", 0, 0, W - 1, H - 1)) +
              attr("displayWindow", "box2i", struct.pack("<4i", 0, 0, W - 1, H - 1)) +
              attr("lineOrder", "lineOrder", b"\0") +
              attr("pixelAspectRatio", "float", struct.pack("<f", 1.0)) +
              attr("screenWindowCenter", "v2f", struct.pack("<2f", 0, 0)) +
              attr("screenWindowWidth", "float", struct.pack("<f", 1.0)) + b"\0")
    lines = []
    for y in range(H):
        data = b""
        for ch in (2, 1, 0):  # B, G, R
            data += b"".join(struct.pack("<f", RGB[y * W + x][ch]) for x in range(W))
        lines.append(struct.pack("<ii", y, len(data)) + data)
    offset = len(header) + 8 * H
    table = b""
    for line in lines:
        table += struct.pack("<Q", offset)
        offset += len(line)
    open(out(rel), "wb").write(header + table + b"".join(lines))


def ply(rel, compress=False):
    # A unit square in z = 0 split into 4 triangles around its centre, with normals and uv.
    verts = [(-1, -1, 0, 0, 0), (1, -1, 0, 1, 0), (1, 1, 0, 1, 1), (-1, 1, 0, 0, 1),
             (0, 0, 0, 0.5, 0.5)]
    text = ("ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
            "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
            "property float u\nproperty float v\nelement face 4\n"
            "property list uchar int vertex_indices\nend_header\n")
    for x, y, z, u, v in verts:
        text += f"{x} {y} {z} 0 0 1 {u} {v}\n"
    for a, b in ((0, 1), (1, 2), (2, 3), (3, 0)):
        text += f"3 {a} {b} 4\n"
    data = text.encode()
    if compress:
        data = gzip.compress(data, mtime=0)
    open(out(rel), "wb").write(data)



# What the stand-ins name (the .spd spectra and the .bsdf file are kept as text/binary files
# beside these and are not generated).
for coll in ("pbrt-v4-scenes", "pbrt-v3-scenes"):
    png(f"{coll}/textures/rgb.png", 3)
    png(f"{coll}/textures/rgba.png", 4)
    png(f"{coll}/textures/gray.png", 1)
    exr(f"{coll}/textures/sky.exr")
    ply(f"{coll}/geometry/quad.ply")
ply("pbrt-v4-scenes/geometry/quad.ply.gz", compress=True)
pfm("pbrt-v3-scenes/textures/rgb.pfm")
