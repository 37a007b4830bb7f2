#!/usr/bin/env python3
"""Writes COUNT mutated .sphb files into OUT_DIR from the given base files (deterministic: the
same arguments always write the same bytes; Python 3 standard library only).

Each file is one base file with one to three mutations (bit flips, bytes set to 0x00/0xFF/random,
a 4-byte-aligned u32 set to an edge value, truncation, extension, a 16-byte block copied over
another); three files in four then get their checksums repaired (section CRCs, table CRC, header
CRC, and the file size field), so the mutations reach the section rules (3xxx-9xxx) instead of
stopping at the checksums (1005, 2003, 2008).

Usage: mutate.py COUNT OUT_DIR BASE.sphb...
       mutate.py repair OUT_DIR FILE...   (checksum-repaired copies, as the load fuzz target reads them)
"""
import random
import struct
import sys
import zlib
from pathlib import Path

EDGE = [0, 1, 2, 3, 15, 16, 17, 63, 64, 92, 255, 256, 0x7FFF, 0x8000, 0xFFFF, 0x10000,
        0x7FFFFFFF, 0x80000000, 0xFFFFFFFE, 0xFFFFFFFF]


def repair(b: bytearray) -> None:
    """Recomputes what a consistent writer would have written around the mutated bytes."""
    if len(b) < 64:
        return
    struct.pack_into("<Q", b, 32, len(b))
    count, table = struct.unpack_from("<IQ", b, 20)
    end = table + 32 * count
    if table % 16 == 0 and 64 <= table and end <= len(b):
        for i in range(count):
            at = table + 32 * i
            off, length = struct.unpack_from("<QQ", b, at + 8)
            if off + length <= len(b):
                struct.pack_into("<I", b, at + 24, zlib.crc32(b[off:off + length]))
        struct.pack_into("<I", b, 40, zlib.crc32(b[table:end]))
    struct.pack_into("<I", b, 44, zlib.crc32(b[:44]))


def mutate(rng: random.Random, b: bytearray) -> None:
    kind = rng.randrange(7)
    n = len(b)
    if n == 0:
        b.extend(bytes(16))
        return
    at = rng.randrange(n)
    if kind == 0:
        b[at] ^= 1 << rng.randrange(8)
    elif kind == 1:
        b[at] = rng.choice([0x00, 0xFF, rng.randrange(256)])
    elif kind == 2 and n >= 4:
        at -= at % 4
        if at + 4 <= n:
            struct.pack_into("<I", b, at, rng.choice(EDGE))
    elif kind == 3:
        del b[rng.choice([at, n - 16 * rng.randrange(1, 4), n - 1]):]
    elif kind == 4:
        b.extend(bytes(16 * rng.randrange(1, 4)) if rng.random() < 0.5 else rng.randbytes(rng.randrange(1, 40)))
    elif kind == 5 and n >= 32:
        src, dst = rng.randrange(n // 16) * 16, rng.randrange(n // 16) * 16
        b[dst:dst + 16] = b[src:src + 16]
    else:
        b[at] = (b[at] + rng.choice([1, -1])) % 256


def main() -> None:
    if sys.argv[1] == "repair":
        out = Path(sys.argv[2])
        out.mkdir(parents=True, exist_ok=True)
        for i, p in enumerate(sys.argv[3:]):
            b = bytearray(Path(p).read_bytes())
            repair(b)
            (out / f"repaired-{i:04}.sphb").write_bytes(bytes(b))
        return
    count, out = int(sys.argv[1]), Path(sys.argv[2])
    bases = [Path(p).read_bytes() for p in sys.argv[3:]]
    out.mkdir(parents=True, exist_ok=True)
    rng = random.Random(0x5EB0)
    for i in range(count):
        b = bytearray(bases[i % len(bases)])
        for _ in range(rng.randint(1, 3)):
            mutate(rng, b)
        if rng.random() < 0.75:
            repair(b)
        (out / f"mutated-{i:04}.sphb").write_bytes(bytes(b))


if __name__ == "__main__":
    main()
