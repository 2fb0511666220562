#!/usr/bin/env python3
"""Writes fogmap_128.png: a 128x128 8-bit greyscale fogmap of fractal value noise.

Deterministic (fixed seed), standard library only. Pixel values are the finest-level
scaling coefficients of a 2D extinction map (0 = clear air, 255 = densest fog); the
render commands scale them by a density parameter. Periodic noise (period 128) so the
map tiles without seams.
"""
import random
import struct
import zlib

N = 128
rng = random.Random(20261122)


def lattice(period):
    return [[rng.random() for _ in range(period)] for _ in range(period)]


def smooth(t):
    return t * t * (3 - 2 * t)


def value_noise(grid, period, x, y):
    fx, fy = x * period / N, y * period / N
    x0, y0 = int(fx), int(fy)
    tx, ty = smooth(fx - x0), smooth(fy - y0)
    g = lambda i, j: grid[j % period][i % period]
    a = g(x0, y0) * (1 - tx) + g(x0 + 1, y0) * tx
    b = g(x0, y0 + 1) * (1 - tx) + g(x0 + 1, y0 + 1) * tx
    return a * (1 - ty) + b * ty


octaves = [(4, 0.5), (8, 0.25), (16, 0.125), (32, 0.0625)]
grids = [(lattice(p), p, w) for p, w in octaves]
total = sum(w for _, w in octaves)
rows = []
for y in range(N):
    row = bytearray([0])  # PNG filter type 0 (None)
    for x in range(N):
        v = sum(w * value_noise(g, p, x, y) for g, p, w in grids) / total
        # Contrast: clear gaps between fog banks.
        v = max(0.0, min(1.0, (v - 0.35) / 0.4))
        row.append(int(round(v * 255)))
    rows.append(bytes(row))


def chunk(kind, body):
    c = struct.pack(">I", len(body)) + kind + body
    return c + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)


png = b"\x89PNG\r\n\x1a\n"
png += chunk(b"IHDR", struct.pack(">IIBBBBB", N, N, 8, 0, 0, 0, 0))
png += chunk(b"IDAT", zlib.compress(b"".join(rows), 9))
png += chunk(b"IEND", b"")
with open("fogmap_128.png", "wb") as f:
    f.write(png)
