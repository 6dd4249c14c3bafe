#!/usr/bin/env python3
"""How fast and how small other chunk compressions would make an MCAP log of drive-sim.

Reads every chunk of LOG (an MCAP file with zstd chunks, as `drive-sim run` writes it),
decompresses it, then times compressing all of them again with zstd at several levels and
with LZ4 (frame format, MCAP's `lz4`), and prints time, size and ratio for each. The README's
"Speed" section chose the chunks' zstd level from this table.

    .venv/bin/python scripts/chunk_compression.py LOG.mcap

Needs the `zstandard` and `lz4` packages (both come with `pip install mcap`).
"""

import argparse
import struct
import sys
import time

import lz4.frame
import zstandard

OP_CHUNK = 0x06
OP_DATA_END = 0x0F
MAGIC_LEN = 8


def chunks(data):
    """The uncompressed records of every chunk of an MCAP file's data section."""
    pos = MAGIC_LEN
    out = []
    while pos < len(data) - MAGIC_LEN:
        op = data[pos]
        (length,) = struct.unpack_from("<Q", data, pos + 1)
        body = data[pos + 9 : pos + 9 + length]
        if op == OP_CHUNK:
            # start, end, uncompressed size (u64 each), uncompressed CRC (u32), compression
            # (string), records (u64 length + bytes)
            p = 8 + 8 + 8 + 4
            (n,) = struct.unpack_from("<I", body, p)
            compression = body[p + 4 : p + 4 + n].decode()
            p += 4 + n
            (records_len,) = struct.unpack_from("<Q", body, p)
            records = body[p + 8 : p + 8 + records_len]
            if compression != "zstd":
                sys.exit(f"chunk compressed with {compression!r}: this script reads zstd chunks")
            out.append(zstandard.ZstdDecompressor().decompress(records))
        if op == OP_DATA_END:
            break
        pos += 9 + length
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("log")
    args = ap.parse_args()
    with open(args.log, "rb") as f:
        data = f.read()
    cs = chunks(data)
    raw = sum(map(len, cs))
    print(f"{args.log}: {len(cs)} chunks, {raw / 1e6:.1f} MB uncompressed")

    def timed(name, compress):
        t0 = time.perf_counter()
        size = sum(len(compress(c)) for c in cs)
        dt = time.perf_counter() - t0
        print(f"{name:16s} {dt * 1e3:8.1f} ms {size / 1e6:8.2f} MB  ratio {raw / size:5.2f}")

    for level in (1, -1, -3, -5):
        c = zstandard.ZstdCompressor(level=level)
        timed(f"zstd {level}", c.compress)
    timed("lz4 frame", lambda c: lz4.frame.compress(c, compression_level=0))


if __name__ == "__main__":
    main()
