"""strandcast.client: an asyncio client of strandcastd (proto/PROTOCOL.md) over Debian's
python3-websockets: the hello, requests answered by their replies (matched by id), frames
decoded by the daemon's C decoder into numpy arrays, and the other messages the server sends.
"""
import asyncio
import itertools
import json
import urllib.parse

import websockets

from .codec import Decoder
from .groom import fetch_groom

SUBPROTOCOL = "strandcast.v3"
DEFAULT_URL = "ws://127.0.0.1:7681/"
_CLOSED = object()  # queue sentinel: the connection ended


class StrandcastError(Exception):
    """An `error` reply. `code` is the protocol's stable code (PROTOCOL.md, "Errors": e.g.
    "out_of_range", "unknown_param", "bad_state"), `field` the path of the offending field
    ("" for the whole message), `message` the server's text, `reply` the whole reply."""

    def __init__(self, reply):
        self.reply = reply
        self.code = reply.get("code")
        self.field = reply.get("field")
        self.message = reply.get("message")
        super().__init__(f"{self.code} (field {self.field!r}): {self.message}")


def _put_newest(queue, item):
    """Puts item into the bounded queue, dropping its oldest entry when full; returns the
    number dropped (0 or 1)."""
    dropped = 0
    if queue.full():
        queue.get_nowait()
        dropped = 1
    queue.put_nowait(item)
    return dropped


class Client:
    """One WebSocket connection to strandcastd. Open it with `async with connect(url) as c`
    or `c = await connect(url)` (then `await c.close()`); use it from one event loop.

    After opening, `hello` holds the server's hello. Frames are decoded as they arrive (the
    decoder must see every keyframe) into a queue of the newest `frame_queue`; older ones are
    dropped and counted in `frames_dropped`. Text messages that answer no pending request
    (announcements such as `params` or `state`, `stats`, errors without an id) wait in a queue
    of the newest 256 for next_message()."""

    def __init__(self, url=DEFAULT_URL, *, library=None, frame_queue=16, timeout=10.0, max_size=1 << 26):
        self.url = url
        self.timeout = timeout
        self.hello = None
        self.frames_dropped = 0
        self._library = library
        self._frame_queue_size = frame_queue
        self._max_size = max_size
        self._ws = None
        self._reader = None
        self._decoder = None
        self._pending = {}
        self._ids = itertools.count(1)
        self._frames = None
        self._messages = None
        self._failure = None  # why the connection ended (an exception), once it has

    async def _open(self):
        self._frames = asyncio.Queue(self._frame_queue_size)
        self._messages = asyncio.Queue(256)
        self._decoder = Decoder(self._library)
        self._ws = await websockets.connect(self.url, subprotocols=[SUBPROTOCOL], max_size=self._max_size,
                                            open_timeout=self.timeout)
        try:
            if self._ws.subprotocol != SUBPROTOCOL:
                raise ConnectionError(f"{self.url}: the server chose subprotocol {self._ws.subprotocol!r}")
            first = json.loads(await asyncio.wait_for(self._ws.recv(), self.timeout))
            if first.get("type") != "hello":
                raise ConnectionError(f"{self.url}: the first message is {first.get('type')!r}, not hello")
        except BaseException:
            await self._ws.close()
            self._decoder.close()
            raise
        self.hello = first
        self._reader = asyncio.get_running_loop().create_task(self._read())
        return self

    def __await__(self):
        return self._open().__await__()

    async def __aenter__(self):
        return await self._open()

    async def __aexit__(self, *exc):
        await self.close()

    async def close(self):
        """Closes the connection (code 1000) and stops reading. Pending requests fail, and so do
        frames() and next_message() (what was queued is dropped)."""
        if self._ws is not None:
            await self._ws.close()
        if self._reader is not None:
            await self._reader
            for queue in (self._frames, self._messages):
                while not queue.empty():
                    queue.get_nowait()
                queue.put_nowait(_CLOSED)
        if self._decoder is not None:
            self._decoder.close()

    async def _read(self):
        """The reader task: dispatches every message until the connection ends."""
        try:
            async for msg in self._ws:
                if isinstance(msg, bytes):
                    self.frames_dropped += _put_newest(self._frames, self._decoder.decode(msg))
                else:
                    self._dispatch(json.loads(msg))
            self._failure = ConnectionError(f"{self.url}: connection closed ({self._ws.close_code} "
                                            f"{self._ws.close_reason!r})")
        except websockets.ConnectionClosed as e:
            self._failure = ConnectionError(f"{self.url}: connection lost ({e})")
        except Exception as e:  # a frame the decoder refused, a message that is not JSON
            self._failure = e
            await self._ws.close(1002, "strandcast client: bad message")
        for fut in self._pending.values():
            if not fut.done():
                fut.set_exception(self._failure)
        _put_newest(self._frames, _CLOSED)
        _put_newest(self._messages, _CLOSED)

    def _dispatch(self, msg):
        fut = self._pending.get(msg.get("id")) if "id" in msg else None
        if fut is not None and not fut.done():
            fut.set_result(msg)
        else:
            _put_newest(self._messages, msg)

    async def send(self, msg):
        """Sends msg (a dict) without waiting for a reply (e.g. `motion` without an id)."""
        await self._ws.send(json.dumps(msg))

    async def request(self, msg, timeout=None):
        """Sends msg (a dict; an `id` is added unless it has one) and returns the reply with its
        id (`ok`, `params`, `subscribed`, ...). Raises StrandcastError on an `error` reply,
        asyncio.TimeoutError after timeout seconds (default: the client's), and the
        connection's failure when it ends first."""
        msg = dict(msg)
        if "id" not in msg:
            msg["id"] = next(self._ids)
        rid = msg["id"]
        if rid in self._pending:
            raise ValueError(f"a request with id {rid!r} is already waiting for its reply")
        if self._failure is not None:
            raise self._failure
        fut = asyncio.get_running_loop().create_future()
        self._pending[rid] = fut
        try:
            await self._ws.send(json.dumps(msg))
            reply = await asyncio.wait_for(fut, self.timeout if timeout is None else timeout)
        finally:
            del self._pending[rid]
        if reply.get("type") == "error":
            raise StrandcastError(reply)
        return reply

    async def frames(self, count=None, timeout=None):
        """Yields (header, positions) for the next count frames (forever when None): header a
        dict of the frame header's fields (strandcast.codec.HEADER_FIELDS: seq, keyframe,
        sim_time, nstrands_sent, nverts, ...), positions a float32 array of shape
        (nstrands_sent, nverts, 3). Raises asyncio.TimeoutError when no frame comes within
        timeout seconds, the connection's failure (a codec.DecodeError for a frame the decoder
        refused) when it ends."""
        n = 0
        while count is None or n < count:
            item = await asyncio.wait_for(self._frames.get(), self.timeout if timeout is None else timeout)
            if item is _CLOSED:
                _put_newest(self._frames, _CLOSED)
                raise self._failure
            n += 1
            yield item

    async def next_message(self, type=None, timeout=None):
        """The next text message that answered no pending request, of the given type when one
        is given (others before it are discarded). Raises asyncio.TimeoutError after timeout
        seconds, the connection's failure when it ends."""
        async def wait():
            while True:
                msg = await self._messages.get()
                if msg is _CLOSED:
                    _put_newest(self._messages, _CLOSED)
                    raise self._failure
                if type is None or msg.get("type") == type:
                    return msg
        return await asyncio.wait_for(wait(), self.timeout if timeout is None else timeout)


    async def groom_data(self, groom=None):
        """The per-strand data of groom (a `groom` object of the hello or of a `groom` message;
        default the hello's), fetched from its `url` on the server: strandcast.groom's dict
        (rest_lengths, roots, etag, ...). Raises ValueError when the server's groom has changed
        since (its etag differs); wait for the `groom` message and ask with its groom."""
        groom = groom or self.hello["groom"]
        parts = urllib.parse.urlsplit(self.url)
        http = urllib.parse.urlunsplit(("https" if parts.scheme == "wss" else "http", parts.netloc,
                                        groom["url"], "", ""))
        data = await asyncio.to_thread(fetch_groom, http, self.timeout)
        if data["etag"] != groom["etag"]:
            raise ValueError(f"{http}: etag {data['etag']}, the groom asked for has {groom['etag']}")
        return data


def connect(url=DEFAULT_URL, **options):
    """A Client for url (options: library, frame_queue, timeout, max_size; see Client), opened
    by `async with` or `await`."""
    return Client(url, **options)
