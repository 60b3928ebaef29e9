"""strandcast.groom: the groom's per-strand data (`GET /groom.bin`, proto/PROTOCOL.md "Groom data
binary"): rest segment lengths and rest root positions, as numpy arrays."""
import struct
import urllib.request

import numpy as np

MAGIC = b"SCGR"
VERSION = 1


def parse_groom_bin(data):
    """The groom data of data (bytes): a dict of strands, verts, rest_lengths (float32, one per
    strand: every segment of strand s has this length) and roots (float32, (strands, 3), head
    frame). Raises ValueError when data is not a version 1 groom data binary of its stated size."""
    if len(data) < 16 or data[:4] != MAGIC:
        raise ValueError("groom.bin: not a groom data binary (magic)")
    version, strands, verts = struct.unpack_from("<III", data, 4)
    if version != VERSION:
        raise ValueError(f"groom.bin: version {version}, this reader reads {VERSION}")
    if strands < 1 or verts < 2 or len(data) != 16 + 16 * strands:
        raise ValueError(f"groom.bin: {len(data)} bytes for {strands} strands x {verts} verts")
    lengths = np.frombuffer(data, dtype="<f4", count=strands, offset=16)
    roots = np.frombuffer(data, dtype="<f4", count=3 * strands, offset=16 + 4 * strands).reshape(strands, 3)
    return {"strands": strands, "verts": verts, "rest_lengths": lengths.astype(np.float32),
            "roots": roots.astype(np.float32)}


def fetch_groom(url, timeout=10.0):
    """GETs the groom data at url (http://HOST:PORT/groom.bin) and parses it; the dict also
    holds the response's `etag` (unquoted: compare it with the hello's or a groom message's
    `groom.etag`). Blocking."""
    with urllib.request.urlopen(url, timeout=timeout) as r:
        etag = (r.headers.get("ETag") or "").strip('"')
        data = r.read()
    return dict(parse_groom_bin(data), etag=etag)
