#!/usr/bin/env python3
"""A small PNG reader (8-bit RGB or RGBA, non-interlaced, as Chromium writes them) for the
browser test: decodes a screenshot with zlib alone and reports how many pixels are not white
and how many have given colours. Usage: png_stats.py FILE.png [#rrggbb ...] -> JSON on stdout."""
import json
import struct
import sys
import zlib
from collections import Counter


def read_png(path):
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG file")
    pos, idat, header = 8, [], None
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
    width, height, depth, colour_type, _, _, interlace = header
    if depth != 8 or colour_type not in (2, 6) or interlace != 0:
        raise ValueError(f"{path}: only 8-bit RGB/RGBA non-interlaced PNGs are supported")
    bpp = 3 if colour_type == 2 else 4
    raw = zlib.decompress(b"".join(idat))
    stride = width * bpp
    rows, previous = [], bytearray(stride)
    low7 = int.from_bytes(b"\x7f" * stride, "big")
    high1 = int.from_bytes(b"\x80" * stride, "big")
    for r in range(height):
        start = r * (stride + 1)
        kind, line = raw[start], bytearray(raw[start + 1:start + 1 + stride])
        if kind == 1:  # Sub
            for i in range(bpp, stride):
                line[i] = (line[i] + line[i - bpp]) & 255
        elif kind == 2:  # Up: byte-wise sum without carries between bytes (SWAR on big ints)
            a, b = int.from_bytes(line, "big"), int.from_bytes(previous, "big")
            line = bytearray((((a & low7) + (b & low7)) ^ ((a ^ b) & high1)).to_bytes(stride, "big"))
        elif kind == 3:  # Average
            for i in range(stride):
                left = line[i - bpp] if i >= bpp else 0
                line[i] = (line[i] + ((left + previous[i]) >> 1)) & 255
        elif kind == 4:  # Paeth
            for i in range(stride):
                a = line[i - bpp] if i >= bpp else 0
                b = previous[i]
                c = previous[i - bpp] if i >= bpp else 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        elif kind != 0:
            raise ValueError(f"{path}: unknown PNG filter {kind}")
        rows.append(bytes(line))
        previous = line
    return width, height, bpp, rows


def stats(path, colours):
    width, height, bpp, rows = read_png(path)
    counts = Counter()
    for line in rows:
        if bpp == 4:
            line = b"".join(line[i:i + 3] for i in range(0, len(line), 4))
        counts.update(line[i:i + 3] for i in range(0, len(line), 3))
    white = counts.get(b"\xff\xff\xff", 0)
    return {
        "width": width,
        "height": height,
        "pixels": width * height,
        "non_white": width * height - white,
        "distinct_colours": len(counts),
        "colours": {c: counts.get(bytes.fromhex(c.lstrip("#")), 0) for c in colours},
    }


if __name__ == "__main__":
    print(json.dumps(stats(sys.argv[1], sys.argv[2:])))
