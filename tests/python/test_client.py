"""The asyncio client (strandcast.Client) and its blocking wrapper against a real strandcastd:
the hello, requests matched to their replies, protocol errors as StrandcastError with the
protocol's code and field, frames decoded into arrays of the hello's shape that agree with the
hello's groom, and subscriptions changing the frames' shape."""
import asyncio

import numpy as np
import pytest

import strandcast


def run(coro):
    return asyncio.run(asyncio.wait_for(coro, 60))


def test_hello(daemon):
    async def body():
        async with strandcast.connect(daemon.url) as c:
            h = c.hello
            assert h["type"] == "hello" and h["protocol"] == 2 and h["subprotocol"] == strandcast.SUBPROTOCOL
            assert h["groom"]["strands"] == 128 and h["groom"]["verts"] == 8
            assert h["stream"]["strands"] == 128 and h["stream"]["stride"] == 1
            assert "gravity" in h["params"]["values"]
    run(body())


def test_set_params_round_trip(daemon):
    async def body():
        async with strandcast.connect(daemon.url) as a, strandcast.connect(daemon.url) as b:
            reply = await a.request({"type": "set_params", "values": {"gravity": 0}, "id": "g0"})
            assert reply == {"type": "ok", "id": "g0", "request": "set_params"}
            # every client is told, with who changed it
            for c in (a, b):
                params = await c.next_message("params")
                assert params["values"] == {"gravity": 0} and params["by"] == a.hello["client"]
            got = await b.request({"type": "get_params"})
            assert got["type"] == "params" and got["values"]["gravity"] == 0 and got["by"] is None
            default = next(p["default"] for p in a.hello["params"]["schema"] if p["name"] == "gravity")
            await a.request({"type": "set_params", "values": {"gravity": default}})
            assert (await b.request({"type": "get_params"}))["values"]["gravity"] == default
    run(body())


@pytest.mark.parametrize("msg, code, field", [
    ({"type": "set_params", "values": {"gravity": -1}}, "out_of_range", "values.gravity"),
    ({"type": "set_params", "values": {"no_such_param": 1}}, "unknown_param", "values.no_such_param"),
    ({"type": "set_params", "values": {"gravity": "high"}}, "bad_field", "values.gravity"),
    ({"type": "teleport"}, "unknown_type", "type"),
    ({"type": "step"}, "bad_state", ""),
])
def test_errors_raise_with_the_protocol_code(daemon, msg, code, field):
    async def body():
        async with strandcast.connect(daemon.url) as c:
            with pytest.raises(strandcast.StrandcastError) as e:
                await c.request(msg)
            assert (e.value.code, e.value.field) == (code, field)
            assert e.value.message and e.value.reply["type"] == "error"
            # the connection stays usable
            assert (await c.request({"type": "get_params"}))["type"] == "params"
    run(body())


def check_frames(hello, frames, strands):
    """Frames of `strands` strands of the hello's groom: finite, strictly increasing seq, roots
    on the hello's rest roots (the head has not moved) and segments of the rest lengths."""
    groom = hello["groom"]
    stride = groom["strands"] // strands
    roots = np.array(groom["roots"], dtype=np.float64).reshape(-1, 3)[::stride]
    rest = np.array(groom["rest_lengths"])[::stride]
    seqs = []
    for header, xyz in frames:
        assert xyz.shape == (strands, groom["verts"], 3) and xyz.dtype == np.float32
        assert header["nstrands_sent"] == strands and header["nstrands_total"] == groom["strands"]
        assert np.isfinite(xyz).all()
        bound = header["max_error_m"] * 1.01
        assert np.abs(xyz[:, 0] - roots).max() <= bound
        seg = np.linalg.norm(np.diff(xyz.astype(np.float64), axis=1), axis=2)
        assert np.abs(seg - rest[:, None]).max() <= 0.02 * rest.max() + 2 * np.sqrt(3) * bound
        seqs.append(header["seq"])
    assert all(b > a for a, b in zip(seqs, seqs[1:]))


def test_frames_decode_to_the_hello_shape(daemon):
    async def body():
        async with strandcast.connect(daemon.url) as c:
            frames = [f async for f in c.frames(count=20)]
            check_frames(c.hello, frames, c.hello["stream"]["strands"])
            assert any(h["keyframe"] for h, _ in frames)
    run(body())


def test_subscribe_changes_the_frames(daemon):
    async def body():
        async with strandcast.connect(daemon.url) as c:
            reply = await c.request({"type": "subscribe", "stride": 4, "max_error": 0.001})
            assert reply["type"] == "subscribed" and reply["stream"]["strands"] == 32
            frames = []
            async for header, xyz in c.frames(count=40):
                if header["stride"] == 4:  # frames of the old stream may still be queued
                    frames.append((header, xyz))
                    if len(frames) == 5:
                        break
            assert len(frames) == 5 and frames[0][0]["keyframe"]
            assert frames[0][0]["max_error_m"] == pytest.approx(0.001)
            check_frames(c.hello, frames, 32)
    run(body())


def test_closed_client_fails_requests(daemon):
    async def body():
        c = await strandcast.connect(daemon.url)
        await c.frames(count=1).__anext__()
        await asyncio.sleep(0.1)  # more frames and messages queue up: close() drops them
        await c.close()
        with pytest.raises(ConnectionError):
            await c.request({"type": "get_params"})
        with pytest.raises(ConnectionError):
            await c.frames(count=1).__anext__()
        with pytest.raises(ConnectionError):
            await c.next_message()
    run(body())


def test_sync_client(daemon):
    with strandcast.SyncClient(daemon.url) as c:
        assert c.hello["groom"]["strands"] == 128
        assert c.request({"type": "get_params"})["type"] == "params"
        with pytest.raises(strandcast.StrandcastError) as e:
            c.request({"type": "animate", "preset": "moonwalk"})
        assert e.value.code == "out_of_range" and e.value.field == "preset"
        check_frames(c.hello, c.frames(5), 128)
