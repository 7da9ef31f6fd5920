#!/usr/bin/env python3
"""Writes small pbrt-v3 tabulated BSDF files ("SCATFUN" format, render/materials/fourier.h):
the seed corpus of the `fourier` fuzz target (fuzz/corpus/fourier/) and the stand-in for the
bathroom scene's paint.bsdf (tests/data/public-scenes/pbrt-v3-scenes/bsdfs/). Valid files are
Lambertian (a_0 = rho/pi |mu_i| for reflection pairs, nothing for transmission pairs; the cdf
rows are the Catmull-Rom integrals of a_0 as pbrt-v3's IntegrateCatmullRom computes them);
the others are corrupted copies. Standard library only; rerunning rewrites the same bytes.
Usage: scripts/make_fourier_seeds.py (from the repository root)."""
import math
import os
import struct


def integrate_catmull_rom(x, f):
    cdf, total = [0.0], 0.0
    n = len(x)
    for i in range(n - 1):
        x0, x1, f0, f1 = x[i], x[i + 1], f[i], f[i + 1]
        w = x1 - x0
        d0 = w * (f1 - f[i - 1]) / (x1 - x[i - 1]) if i > 0 else f1 - f0
        d1 = w * (f[i + 2] - f0) / (x[i + 2] - x0) if i + 2 < n else f1 - f0
        total += ((d0 - d1) / 12 + (f0 + f1) / 2) * w
        cdf.append(total)
    return cdf


def lambert(n_mu=9, rho=(0.8, 0.8, 0.8), eta=1.0, flags=1, n_bases=1):
    """rho: (Y, R, B) albedos; one channel when all three are equal."""
    channels = 1 if rho[0] == rho[1] == rho[2] else 3
    mu = [-1 + 2 * i / (n_mu - 1) for i in range(n_mu)]
    coeffs, pairs, cdf = [], [], []
    for o in range(n_mu):
        row = []
        for i in range(n_mu):
            refl = mu[i] * mu[o] < 0
            a0 = [r / math.pi * abs(mu[i]) for r in rho[:channels]] if refl else None
            row.append(a0[0] if a0 else 0.0)
            if a0:
                pairs.append((len(coeffs), 1))
                coeffs.extend(a0)
            else:
                pairs.append((0, 0))
        cdf.extend(integrate_catmull_rom(mu, row))
    head = b"SCATFUN\x01" + struct.pack("<6i3if4i", flags, n_mu, len(coeffs), 1, channels,
                                        n_bases, 0, 0, 0, eta, 0, 0, 0, 0)
    body = struct.pack(f"<{n_mu}f", *mu) + struct.pack(f"<{len(cdf)}f", *cdf)
    body += b"".join(struct.pack("<2i", off, ln) for off, ln in pairs)
    body += struct.pack(f"<{len(coeffs)}f", *coeffs)
    return head + body


def write(path, data):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(data)


def main():
    d = "fuzz/corpus/fourier"
    good = lambert()
    write(f"{d}/lambert.bsdf", good)
    write(f"{d}/lambert_rgb.bsdf", lambert(n_mu=5, rho=(0.5, 0.7, 0.2)))
    write(f"{d}/lambert_eta.bsdf", lambert(n_mu=4, eta=1.5))
    write(f"{d}/truncated.bsdf", good[: len(good) - 7])
    write(f"{d}/header_only.bsdf", good[:40])
    write(f"{d}/bad_magic.bsdf", b"SCATFUN\x02" + good[8:])
    write(f"{d}/flags2.bsdf", lambert(flags=2))
    write(f"{d}/two_bases.bsdf", lambert(n_bases=2))
    huge = bytearray(good)
    huge[12:16] = struct.pack("<i", 1 << 30)  # nMu: 2^60 pairs claimed
    write(f"{d}/huge_nmu.bsdf", bytes(huge))
    neg = bytearray(good)
    neg[16:20] = struct.pack("<i", -5)  # nCoeffs
    write(f"{d}/negative_ncoeffs.bsdf", bytes(neg))
    nan_mu = bytearray(good)
    nan_mu[64 + 4 * 3: 64 + 4 * 4] = struct.pack("<f", float("nan"))
    write(f"{d}/nan_mu.bsdf", bytes(nan_mu))
    dec = bytearray(good)
    dec[64 + 4 * 2: 64 + 4 * 3] = struct.pack("<f", -0.9)
    write(f"{d}/decreasing_mu.bsdf", bytes(dec))
    n_mu = 9
    pair0 = 64 + 4 * (n_mu + n_mu * n_mu)
    out = bytearray(good)
    out[pair0 + 8 * 5: pair0 + 8 * 6] = struct.pack("<2i", 1 << 30, 1)  # offset far outside
    write(f"{d}/offset_outside.bsdf", bytes(out))
    inf_c = bytearray(good)
    inf_c[len(good) - 4:] = struct.pack("<f", float("inf"))
    write(f"{d}/inf_coefficient.bsdf", bytes(inf_c))
    write("tests/data/public-scenes/pbrt-v3-scenes/bsdfs/paint.bsdf", lambert(rho=(0.8, 0.8, 0.8)))


if __name__ == "__main__":
    main()
