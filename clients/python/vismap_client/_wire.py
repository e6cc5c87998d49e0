"""What the compact and delta readers share (proto/COMPACT.md): a section's LEB128 numbers, zigzag,
and the payload's decompression. `fail(part, message)` raises the reader's own ValueError."""
import zlib

import numpy as np


def leb128(sec, part, fail):
    """Every LEB128 number of `sec` (at most 10 bytes each; 64-bit wrap as in C++: a 10th group
    keeps only its low bit), as uint64; the section must end at a number's end."""
    b = np.frombuffer(sec, np.uint8)
    if len(b) and b[-1] >= 0x80:
        fail(part, "ends inside a number")
    ends = np.flatnonzero(b < 0x80)
    if len(ends) == 0:
        return np.zeros(0, np.uint64)
    starts = np.empty_like(ends)
    starts[0] = 0
    starts[1:] = ends[:-1] + 1
    lengths = ends - starts + 1
    longest = int(lengths.max())
    if longest > 10:
        fail(part, "a number longer than 64 bits")
    groups = (b & 0x7F).astype(np.uint64)
    z = groups[starts]
    for k in range(1, longest):  # the k-th 7-bit group of the numbers that have one
        z |= np.where(lengths > k, groups[np.minimum(starts + k, len(b) - 1)], 0).astype(np.uint64) \
            << np.uint64(7 * k)
    return z


def unzigzag(z):
    """Zigzag-coded uint64 to int64: 2s for s >= 0, -2s - 1 for s < 0."""
    z = np.asarray(z, np.uint64)
    return (z >> np.uint64(1)).astype(np.int64) ^ -(z & np.uint64(1)).astype(np.int64)


def inflate(codec, z, size, fail):
    """The payload: exactly `size` bytes from one zstd frame (codec 1) or one raw deflate stream
    (codec 2) that ends exactly at the message's end. (After a zstd frame nothing may follow, where
    libzstd would also skip empty or skippable frames.)"""
    if codec == 1:
        try:
            import zstandard
        except ImportError as e:
            raise ImportError("zstd frames need the zstandard module (Debian: python3-zstandard); "
                              "or ask the server for compression: deflate") from e
        try:
            content = zstandard.get_frame_parameters(z).content_size
            if content != size:
                fail("payload", "not one zstd frame of the stated size")
            out = zstandard.ZstdDecompressor().decompress(z, allow_extra_data=False)
        except zstandard.ZstdError as e:
            fail("payload", f"zstd: {e}")
    else:
        d = zlib.decompressobj(-15)
        try:
            out = d.decompress(z, size + 1)  # one byte more than stated shows a longer stream
        except zlib.error as e:
            fail("payload", f"deflate: {e}")
        if not d.eof or d.unused_data or d.unconsumed_tail:
            fail("payload", "not one raw deflate stream ending at the message's end")
    if len(out) != size:
        fail("payload", f"{len(out)} bytes after decompression, the header says {size}")
    return out
