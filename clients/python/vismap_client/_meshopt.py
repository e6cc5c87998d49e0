"""meshoptimizer's index codec decoder through ctypes, on the system's shared library (Debian:
libmeshoptimizer2d, soname libmeshoptimizer.so.2d). $VISMAP_MESHOPT_LIB names another file.
Loaded on first use, so the package imports (and reads bin frames) without it."""
import ctypes
import ctypes.util
import os

import numpy as np

_NAMES = ("libmeshoptimizer.so.2d", "libmeshoptimizer.so.2", "libmeshoptimizer.so")
_decode = None


def _load():
    global _decode
    names = [os.environ["VISMAP_MESHOPT_LIB"]] if os.environ.get("VISMAP_MESHOPT_LIB") else []
    names += list(_NAMES) + [ctypes.util.find_library("meshoptimizer")]
    for name in names:
        if not name:
            continue
        try:
            lib = ctypes.CDLL(name)
        except OSError:
            continue
        f = lib.meshopt_decodeIndexBuffer
        # int meshopt_decodeIndexBuffer(void* destination, size_t index_count, size_t index_size,
        #                               const unsigned char* buffer, size_t buffer_size)
        f.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_size_t, ctypes.c_char_p, ctypes.c_size_t]
        f.restype = ctypes.c_int
        _decode = f
        return f
    raise ImportError("compact frames need meshoptimizer's shared library (Debian: apt-get install "
                      "libmeshoptimizer2d), or $VISMAP_MESHOPT_LIB naming it")


def decode_index_buffer(index_count: int, buf: bytes) -> np.ndarray:
    """`index_count` (a multiple of 3) uint32 indices from the codec's bytes; ValueError (naming
    the indices section) when the codec refuses them."""
    f = _decode or _load()
    out = np.empty(index_count, np.uint32)
    rc = f(out.ctypes.data_as(ctypes.c_void_p), index_count, 4, buf, len(buf))
    if rc != 0:
        raise ValueError(f"compact frame: indices: meshoptimizer's index codec refused them ({rc})")
    return out
