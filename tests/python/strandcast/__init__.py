"""strandcast: a Python client of strandcastd for tests (pytest or plain asyncio).

    async with strandcast.connect("ws://127.0.0.1:7681/") as client:
        client.hello                                   # the server's hello
        await client.request({"type": "set_params", "values": {"gravity": 0}})
        async for header, xyz in client.frames(count=10): ...   # xyz: (strands, verts, 3) float32

Modules: client (the asyncio client, StrandcastError), sync (SyncClient, blocking), codec (the
C decoder through ctypes: Decoder, DecodeError), groom (the groom data: rest lengths, roots),
daemon (a strandcastd child for tests).
"""
from .client import DEFAULT_URL, SUBPROTOCOL, Client, StrandcastError, connect
from .codec import DecodeError, Decoder
from .daemon import Daemon
from .sync import SyncClient

__all__ = ["DEFAULT_URL", "SUBPROTOCOL", "Client", "StrandcastError", "connect", "DecodeError", "Decoder",
           "Daemon", "SyncClient"]
