"""The asyncio client (strandcast.Client) and its blocking wrapper against a real strandcastd:
the hello, the groom data, requests matched to their replies, protocol errors as StrandcastError
with the protocol's code and field, frames decoded into arrays of the hello's shape that agree
with the groom data and the frames' head transform, and subscriptions changing their shape."""
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
            assert h["type"] == "hello" and h["protocol"] == 3 and h["subprotocol"] == strandcast.SUBPROTOCOL
            assert h["groom"]["strands"] == 128 and h["groom"]["verts"] == 8
            assert h["stream"]["strands"] == 128 and h["stream"]["stride"] == 1
            assert "gravity" in h["params"]["values"]
    run(body())


def test_set_params_round_trip(daemon):
    async def body():
        async with strandcast.connect(daemon.url) as a, strandcast.connect(daemon.url) as b:
            reply = await a.request({"type": "set_params", "values": {"gravity": 0}, "id": "g0"})
            step = reply.pop("step")  # the step the change shows at
            assert reply == {"type": "ok", "id": "g0", "request": "set_params"} and step >= 0
            # every client is told, with who changed it
            for c in (a, b):
                params = await c.next_message("params")
                assert params["values"]["gravity"] == 0 and params["changed"] == ["gravity"] and params["by"] == a.hello["client"]
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


def rotate(q, v):
    """v (n, 3) rotated by the unit quaternion q = (x, y, z, w)."""
    u, w = np.asarray(q[:3], dtype=np.float64), float(q[3])
    t = 2 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def check_frames(hello, groom, frames, strands):
    """Frames of `strands` strands of the hello's groom (groom: its groom data): finite, strictly
    increasing seq and sim_step, roots on the rest roots moved by the frame's head transform, and
    segments of the rest lengths."""
    stride = hello["groom"]["strands"] // strands
    roots = groom["roots"].astype(np.float64)[::stride]
    rest = groom["rest_lengths"].astype(np.float64)[::stride]
    seqs, steps = [], []
    for header, xyz in frames:
        assert xyz.shape == (strands, hello["groom"]["verts"], 3) and xyz.dtype == np.float32
        assert header["nstrands_sent"] == strands and header["nstrands_total"] == hello["groom"]["strands"]
        assert np.isfinite(xyz).all()
        bound = header["max_error_m"] * 1.01
        want = rotate(header["head_orientation"], roots) + header["head_position"]
        assert np.abs(xyz[:, 0] - want).max() <= bound + 1e-6
        seg = np.linalg.norm(np.diff(xyz.astype(np.float64), axis=1), axis=2)
        assert np.abs(seg - rest[:, None]).max() <= 0.02 * rest.max() + 2 * np.sqrt(3) * bound
        seqs.append(header["seq"])
        steps.append(header["sim_step"])
    assert all(b > a for a, b in zip(seqs, seqs[1:])) and all(b > a for a, b in zip(steps, steps[1:]))


def test_groom_data(daemon):
    async def body():
        async with strandcast.connect(daemon.url) as c:
            groom = await c.groom_data()
            assert groom["strands"] == 128 and groom["verts"] == 8 and groom["etag"] == c.hello["groom"]["etag"]
            assert groom["roots"].shape == (128, 3) and (groom["rest_lengths"] > 0).all()
            lo, hi = np.array(c.hello["groom"]["bounds"][:3]), np.array(c.hello["groom"]["bounds"][3:])
            assert ((groom["roots"] >= lo - 1e-6) & (groom["roots"] <= hi + 1e-6)).all()
            with pytest.raises(ValueError, match="etag"):
                await c.groom_data(dict(c.hello["groom"], etag="0000000000000000"))
    run(body())


def test_frames_decode_to_the_hello_shape(daemon):
    async def body():
        async with strandcast.connect(daemon.url) as c:
            frames = [f async for f in c.frames(count=20)]
            check_frames(c.hello, await c.groom_data(), frames, c.hello["stream"]["strands"])
            assert any(h["keyframe"] for h, _ in frames)
    run(body())


def test_frames_carry_the_head_motion(daemon):
    async def body():
        async with strandcast.connect(daemon.url) as c:
            pos, rot = [0.05, 0.02, -0.01], [0, 0.25881904, 0, 0.96592583]  # 30 degrees about y
            reply = await c.request({"type": "motion", "position": pos, "orientation": rot})
            moved = []
            async for header, xyz in c.frames(count=120):
                if header["sim_step"] >= reply["step"]:
                    moved.append((header, xyz))
                    if len(moved) == 3:
                        break
            assert len(moved) == 3
            for header, _ in moved:
                assert header["head_position"] == pytest.approx(pos, abs=1e-6)
                assert header["head_orientation"] == pytest.approx(rot, abs=1e-6)
            check_frames(c.hello, await c.groom_data(), moved, 128)
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
            check_frames(c.hello, await c.groom_data(), frames, 32)
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
        check_frames(c.hello, c.groom_data(), c.frames(5), 128)


def test_hairmesh_frames_say_their_codec():
    """A client subscribed to the hair mesh gets hair mesh frames (codec_id 2) of the mesh's
    columns x layers, and strand frames (codec_id 1) again after it subscribes back."""
    async def body(url):
        async with strandcast.connect(url) as c:
            mesh = c.hello["groom"]["hairmesh"]
            reply = await c.request({"type": "subscribe", "source": "hairmesh"})
            assert reply["stream"]["codec"] == "hairmesh" and reply["stream"]["strands"] == mesh["ncols"]
            got = []
            async for header, xyz in c.frames(count=60):
                if header["codec_id"] == 2:  # strand frames of the old stream may still be queued
                    got.append((header, xyz))
                    if len(got) == 3:
                        break
            assert len(got) == 3
            for header, xyz in got:
                assert xyz.shape == (mesh["ncols"], mesh["nlayers"], 3) and np.isfinite(xyz).all()
            await c.request({"type": "subscribe", "source": "strands"})
            async for header, xyz in c.frames(count=60):
                if header["codec_id"] == 1:
                    assert xyz.shape == (c.hello["stream"]["strands"], c.hello["groom"]["verts"], 3)
                    break
            else:
                pytest.fail("no strand frame after subscribing back to the strands")
    with strandcast.Daemon("--groom", "hairmesh:straight", "--solver", "hairmesh") as d:
        run(body(d.url))
