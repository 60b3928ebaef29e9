"""The client against a scripted server (websockets.serve): replies matched by id when they come
out of order, a corrupt frame from the server raised as DecodeError from frames() (and the
connection then closed with 1002, pending requests failing), a first message that is not hello
refused."""
import asyncio
import json

import pytest
import websockets

import strandcast
from strandcast import codec

VECTORS = codec.source_dir() / "proto" / "vectors"
HELLO = {"type": "hello", "protocol": 3, "subprotocol": strandcast.SUBPROTOCOL, "client": 1}


async def serve(handler, body):
    """Runs body(url) against a server whose connections handler(ws) serves."""
    async with websockets.serve(handler, "127.0.0.1", 0, subprotocols=[strandcast.SUBPROTOCOL]) as server:
        port = next(iter(server.sockets)).getsockname()[1]
        await asyncio.wait_for(body(f"ws://127.0.0.1:{port}/"), 30)


def test_replies_out_of_order_and_a_corrupt_frame():
    closed = asyncio.Event()

    async def handler(ws):
        await ws.send(json.dumps(HELLO))
        first, second = json.loads(await ws.recv()), json.loads(await ws.recv())
        await ws.send(json.dumps({"type": "stats", "steps": 1}))
        await ws.send(json.dumps({"type": "ok", "id": second["id"], "request": second["type"]}))
        await ws.send(json.dumps({"type": "error", "id": first["id"], "code": "out_of_range",
                                  "field": "values.gravity", "message": "too low"}))
        key = (VECTORS / "basic_0.bin").read_bytes()
        await ws.send(key)
        await ws.send(key[:-1])  # truncated
        await ws.wait_closed()
        assert ws.close_code == 1002
        closed.set()

    async def body(url):
        async with strandcast.connect(url) as c:
            assert c.hello == HELLO
            low = asyncio.ensure_future(c.request({"type": "set_params", "values": {"gravity": -1}}))
            await asyncio.sleep(0.05)  # the server reads the requests in this order
            ok = await c.request({"type": "pause"})
            assert ok == {"type": "ok", "id": 2, "request": "pause"}
            with pytest.raises(strandcast.StrandcastError) as e:
                await low
            assert (e.value.code, e.value.field, e.value.message) == ("out_of_range", "values.gravity", "too low")
            assert (await c.next_message())["type"] == "stats"
            frames = c.frames()
            header, xyz = await frames.__anext__()
            assert header["keyframe"] and xyz.shape == (24, 12, 3)
            with pytest.raises(strandcast.DecodeError) as e:
                await frames.__anext__()
            assert e.value.code == "bad_format" and "truncated" in e.value.message
            with pytest.raises(strandcast.DecodeError):
                await c.request({"type": "resume"})
            await asyncio.wait_for(closed.wait(), 10)

    asyncio.run(serve(handler, body))


def test_first_message_must_be_hello():
    async def handler(ws):
        await ws.send(json.dumps({"type": "stats"}))
        await ws.wait_closed()

    async def body(url):
        with pytest.raises(ConnectionError, match="not hello"):
            await strandcast.connect(url)

    asyncio.run(serve(handler, body))
