"""strandcast.codec: the daemon's strand-frame decoder (proto/CODEC.md) through ctypes.

The decoder is the C one, built as libstrandcast_codec.so from server/codec/ with the small
stable ABI of server/codec/codec_abi.h: an opaque handle, int status codes, one accessor per
header field. Frames decode to numpy float32 arrays of shape (nstrands_sent, nverts, 3).
"""
import ctypes
import functools
import os
import pathlib

import numpy as np

ABI_VERSION = 1
LIBRARY_NAME = "libstrandcast_codec.so"

# The header fields (proto/CODEC.md) as (name, C type, count): a scalar (count 1) is read by the
# accessor `T codec_abi_<name>(d)`, a vector by `void codec_abi_<name>(d, T out[count])` (a list
# in the header dict). A field the format gains is one entry here and one accessor in codec_abi.h.
HEADER_FIELDS = (
    ("seq", ctypes.c_uint64, 1),
    ("ref_seq", ctypes.c_uint64, 1),
    ("keyframe", ctypes.c_int, 1),
    ("sim_time", ctypes.c_double, 1),
    ("sim_step", ctypes.c_uint64, 1),
    ("head_position", ctypes.c_float, 3),
    ("head_orientation", ctypes.c_float, 4),
    ("step", ctypes.c_double, 1),
    ("max_error_m", ctypes.c_float, 1),
    ("nstrands_total", ctypes.c_uint32, 1),
    ("nstrands_sent", ctypes.c_uint32, 1),
    ("nverts", ctypes.c_uint32, 1),
    ("stride", ctypes.c_uint32, 1),
    ("codec_id", ctypes.c_uint32, 1),
    ("payload_len", ctypes.c_uint32, 1),
    ("frame_len", ctypes.c_uint64, 1),
)


class DecodeError(ValueError):
    """A frame the decoder refused. `code` is the decoder's status name ("bad_format" for a
    corrupt, truncated or inconsistent frame, "bad_state" for a delta whose keyframe is not
    held, "invalid_argument"), `message` says what is wrong and at which byte."""

    def __init__(self, code, message):
        super().__init__(f"{code}: {message}")
        self.code = code
        self.message = message


def source_dir():
    """The strandcast source tree this package lives in (tests/python/strandcast/ in it)."""
    return pathlib.Path(__file__).resolve().parents[3]


def build_dir():
    """Where the built programs and library are: $STRANDCAST_BUILD_DIR, else <source>/build."""
    return pathlib.Path(os.environ.get("STRANDCAST_BUILD_DIR") or source_dir() / "build")


def library_path():
    """The decoder library to load: $STRANDCAST_CODEC_LIB, else the build directory's."""
    return os.environ.get("STRANDCAST_CODEC_LIB") or str(build_dir() / LIBRARY_NAME)


@functools.lru_cache(maxsize=None)
def load_library(path=None):
    """Loads the decoder library (path, default library_path()) with its functions' types
    declared, once per path. Raises OSError when it cannot be loaded and RuntimeError when its
    ABI version is not the one this module speaks."""
    lib = ctypes.CDLL(path or library_path())
    handle = ctypes.c_void_p
    lib.codec_abi_version.restype = ctypes.c_uint32
    lib.codec_abi_version.argtypes = []
    if lib.codec_abi_version() != ABI_VERSION:
        raise RuntimeError(f"{path or library_path()}: codec ABI version {lib.codec_abi_version()}, "
                           f"this module speaks {ABI_VERSION}")
    lib.codec_abi_format_version.restype = ctypes.c_uint32
    lib.codec_abi_format_version.argtypes = []
    lib.codec_abi_status_name.restype = ctypes.c_char_p
    lib.codec_abi_status_name.argtypes = [ctypes.c_int]
    lib.codec_abi_decoder_new.restype = handle
    lib.codec_abi_decoder_new.argtypes = []
    lib.codec_abi_decoder_free.restype = None
    lib.codec_abi_decoder_free.argtypes = [handle]
    lib.codec_abi_peek.restype = ctypes.c_int
    lib.codec_abi_peek.argtypes = [handle, ctypes.c_char_p, ctypes.c_size_t]
    lib.codec_abi_decode.restype = ctypes.c_int
    lib.codec_abi_decode.argtypes = [handle, ctypes.c_char_p, ctypes.c_size_t,
                                     ctypes.POINTER(ctypes.c_float), ctypes.c_size_t]
    lib.codec_abi_message.restype = ctypes.c_char_p
    lib.codec_abi_message.argtypes = [handle]
    for name, ctype, count in HEADER_FIELDS:
        f = getattr(lib, "codec_abi_" + name)
        f.restype = ctype if count == 1 else None
        f.argtypes = [handle] if count == 1 else [handle, ctypes.POINTER(ctype)]
    return lib


def format_version(library=None):
    """The strand frame format version the library reads."""
    return load_library(library).codec_abi_format_version()


class Decoder:
    """One stream's decoder: it holds the last keyframe, so feed it every frame of a stream in
    order (deltas may be skipped). Not thread-safe; close() (or `with`) frees it."""

    def __init__(self, library=None):
        self._d = None
        self._lib = load_library(library)
        self._d = self._lib.codec_abi_decoder_new()
        if not self._d:
            raise MemoryError("codec: out of memory for a decoder")

    def close(self):
        """Frees the decoder; it may not be used afterwards. Safe to call twice."""
        if self._d:
            self._lib.codec_abi_decoder_free(self._d)
            self._d = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        self.close()

    def _check(self, status):
        if status:
            raise DecodeError(self._lib.codec_abi_status_name(status).decode(),
                              self._lib.codec_abi_message(self._d).decode(errors="replace"))

    def _handle(self):
        if not self._d:
            raise ValueError("codec: the decoder is closed")
        return self._d

    def _field(self, name, ctype, count):
        f = getattr(self._lib, "codec_abi_" + name)
        if count == 1:
            return f(self._d)
        out = (ctype * count)()
        f(self._d, out)
        return list(out)

    def _fields(self):
        h = {name: self._field(name, ctype, count) for name, ctype, count in HEADER_FIELDS}
        h["keyframe"] = bool(h["keyframe"])
        return h

    def header(self, frame):
        """The header of frame (bytes-like) as a dict of HEADER_FIELDS, validated but not
        decoded (the CRC is not checked). Raises DecodeError for a bad header."""
        data = bytes(frame)
        self._check(self._lib.codec_abi_peek(self._handle(), data, len(data)))
        return self._fields()

    def decode(self, frame):
        """Decodes frame (bytes-like): returns (header dict, positions), positions a new
        float32 array of shape (nstrands_sent, nverts, 3): strands 0, stride, 2 stride, ...
        Raises DecodeError for a corrupt frame or a delta whose keyframe is not held; the
        held keyframe is then unchanged."""
        data = bytes(frame)
        h = self.header(data)
        out = np.empty((h["nstrands_sent"], h["nverts"], 3), dtype=np.float32)
        ptr = out.ctypes.data_as(ctypes.POINTER(ctypes.c_float))
        self._check(self._lib.codec_abi_decode(self._handle(), data, len(data), ptr, out.size))
        return self._fields(), out
