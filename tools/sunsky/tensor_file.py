"""Reader of Mitsuba 3's `tensor_file` format (the sunsky datasets ship in it).

Layout (little-endian): the 12 bytes "tensor_file\\0", u16 version (1), u32 field count, then per
field: u16 name length, the name, u16 rank, u8 dtype code, u64 byte offset of the data, u64 per
dimension; the data are C-ordered arrays at their offsets.
"""

import struct

import numpy as np

# Dr.Jit VarType codes used by the format.
DTYPES = {10: np.float32, 11: np.float64, 5: np.int32, 6: np.uint32, 7: np.int64, 8: np.uint64}


def read(path):
    """Return {name: numpy array} for every field of the file at `path`."""
    raw = open(path, "rb").read()
    if raw[:12] != b"tensor_file\0":
        raise ValueError(f"{path}: not a Mitsuba tensor file")
    version, count = struct.unpack_from("<HI", raw, 12)
    if version != 1:
        raise ValueError(f"{path}: unsupported tensor file version {version}")
    pos = 18
    out = {}
    for _ in range(count):
        (n,) = struct.unpack_from("<H", raw, pos)
        pos += 2
        name = raw[pos : pos + n].decode()
        pos += n
        rank, code, offset = struct.unpack_from("<HBQ", raw, pos)
        pos += 11
        shape = struct.unpack_from(f"<{rank}Q", raw, pos)
        pos += 8 * rank
        dtype = DTYPES[code]
        size = int(np.prod(shape))
        out[name] = np.frombuffer(raw, dtype=dtype, count=size, offset=offset).reshape(shape)
    return out
