"""strandcast.sync: a blocking wrapper of the asyncio Client, for tests that want no event loop.

It runs the client on an event loop of its own, only while one of its calls runs: frames that
arrive in between wait in the socket (the server skips frames for a client that reads slowly),
so frames() returns frames that may be a little older than the call.
"""
import asyncio

from .client import DEFAULT_URL, Client


class SyncClient:
    """A Client (same options) driven by blocking calls; `with SyncClient(url) as c:` or
    close(). One thread uses it."""

    def __init__(self, url=DEFAULT_URL, **options):
        self._loop = asyncio.new_event_loop()
        try:
            self._client = self._loop.run_until_complete(Client(url, **options)._open())
        except BaseException:
            self._loop.close()
            raise

    @property
    def hello(self):
        """The server's hello message."""
        return self._client.hello

    @property
    def frames_dropped(self):
        """Frames dropped because the frame queue was full (see Client)."""
        return self._client.frames_dropped

    def request(self, msg, timeout=None):
        """Client.request: the reply, or StrandcastError on an `error` reply."""
        return self._loop.run_until_complete(self._client.request(msg, timeout))

    def send(self, msg):
        """Client.send: sends msg without waiting for a reply."""
        self._loop.run_until_complete(self._client.send(msg))

    def frames(self, count, timeout=None):
        """The next count frames as a list of (header, positions) (Client.frames)."""
        async def take():
            return [f async for f in self._client.frames(count, timeout)]
        return self._loop.run_until_complete(take())

    def groom_data(self, groom=None):
        """Client.groom_data: the groom's rest lengths and roots."""
        return self._loop.run_until_complete(self._client.groom_data(groom))

    def next_message(self, type=None, timeout=None):
        """Client.next_message."""
        return self._loop.run_until_complete(self._client.next_message(type, timeout))

    def close(self):
        """Closes the connection and the event loop. Safe to call twice."""
        if not self._loop.is_closed():
            self._loop.run_until_complete(self._client.close())
            self._loop.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
