#!/usr/bin/env python3
"""exr-layer-png.py IN.exr OUT.png [--layer NAME] [--scale S]

Writes one layer of a lensim EXR (scanline, ZIP or no compression, half or float channels) as an
8-bit sRGB PNG: the channels NAME.R, NAME.G, NAME.B (no --layer: R, G, B) times S, clipped to
[0, 1]. Python's standard library only (zlib, struct): lensim writes the flare's ghost layer as
EXR channels ghost.R/G/B, which PNG cannot hold (docs/flare.md).
"""
import argparse
import struct
import sys
import zlib


def fail(msg):
    sys.exit(f"exr-layer-png: {msg}")


def read_header(data):
    if data[:4] != b"\x76\x2f\x31\x01":
        fail("not an OpenEXR file")
    if data[5] & 0x1e:  # tiled, long names, deep or multipart
        fail("only single-part scanline EXR files are read")
    pos, attrs = 8, {}
    while data[pos] != 0:
        end = data.index(b"\0", pos)
        name = data[pos:end].decode()
        tend = data.index(b"\0", end + 1)
        kind = data[end + 1:tend].decode()
        (size,) = struct.unpack_from("<i", data, tend + 1)
        attrs[name] = (kind, data[tend + 5:tend + 5 + size])
        pos = tend + 5 + size
    return attrs, pos + 1


def channels(raw):
    out, pos = [], 0
    while raw[pos] != 0:
        end = raw.index(b"\0", pos)
        name = raw[pos:end].decode()
        ptype, _, _, xs, ys = struct.unpack_from("<iB3sii", raw, end + 1)
        if xs != 1 or ys != 1:
            fail(f"channel {name} is subsampled")
        out.append((name, ptype))
        pos = end + 1 + 16
    return out


def unzip(block, expected):
    if len(block) == expected:
        return block
    t = bytearray(zlib.decompress(block))
    for i in range(1, len(t)):
        t[i] = (t[i - 1] + t[i] - 128) & 0xFF
    half = (len(t) + 1) // 2
    out = bytearray(len(t))
    out[0::2] = t[:half]
    out[1::2] = t[half:]
    return bytes(out)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("exr")
    ap.add_argument("png")
    ap.add_argument("--layer", default="")
    ap.add_argument("--scale", type=float, default=1.0)
    a = ap.parse_args()
    data = open(a.exr, "rb").read()
    attrs, pos = read_header(data)
    chans = channels(attrs["channels"][1])
    comp = attrs["compression"][1][0]
    lines_per_block = {0: 1, 2: 1, 3: 16}.get(comp)
    if lines_per_block is None:
        fail(f"compression {comp} (expected none, ZIPS or ZIP)")
    x0, y0, x1, y1 = struct.unpack("<4i", attrs["dataWindow"][1])
    w, h = x1 - x0 + 1, y1 - y0 + 1
    size = {1: 2, 2: 4}
    if any(p not in size for _, p in chans):
        fail("only half and float channels are read")
    want = [(a.layer + "." if a.layer else "") + c for c in "RGB"]
    names = [n for n, _ in chans]
    for n in want:
        if n not in names:
            fail(f"{a.exr} has no channel {n} (it has {', '.join(names)})")
    blocks = (h + lines_per_block - 1) // lines_per_block
    offsets = struct.unpack_from(f"<{blocks}Q", data, pos)
    rgb = [[0.0] * (w * h) for _ in range(3)]
    for off in offsets:
        y, n = struct.unpack_from("<ii", data, off)
        lines = min(lines_per_block, y1 - y + 1)
        line_bytes = sum(size[p] for _, p in chans) * w
        raw = unzip(data[off + 8:off + 8 + n], line_bytes * lines)
        p = 0
        for ly in range(lines):
            row = y - y0 + ly
            for name, ptype in chans:
                nb = size[ptype] * w
                if name in want:
                    vals = struct.unpack_from(f"<{w}{'e' if ptype == 1 else 'f'}", raw, p)
                    rgb[want.index(name)][row * w:(row + 1) * w] = vals
                p += nb

    def srgb(v):
        v = min(1.0, max(0.0, v * a.scale))
        v = 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055
        return int(v * 255 + 0.5)

    rows = bytearray()
    for y in range(h):
        rows.append(0)
        for x in range(w):
            i = y * w + x
            rows += bytes((srgb(rgb[0][i]), srgb(rgb[1][i]), srgb(rgb[2][i])))

    def chunk(tag, body):
        c = tag + body
        return struct.pack(">I", len(body)) + c + struct.pack(">I", zlib.crc32(c) & 0xFFFFFFFF)

    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
           chunk(b"IDAT", zlib.compress(bytes(rows), 9)) + chunk(b"IEND", b""))
    open(a.png, "wb").write(png)


if __name__ == "__main__":
    main()
