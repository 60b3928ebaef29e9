"""The C decoder through ctypes (strandcast.codec) on the stored test vectors (proto/vectors):
bit-exact positions and header fields, and DecodeError with the decoder's status for corrupt,
truncated and out-of-order frames."""
import json

import numpy as np
import pytest

import strandcast
from strandcast import codec

VECTORS = codec.source_dir() / "proto" / "vectors"
MANIFEST = json.loads((VECTORS / "manifest.json").read_text())


def frame(name):
    return (VECTORS / f"{name}.bin").read_bytes()


def positions(name, stream):
    want = np.fromfile(VECTORS / f"{name}.out.f32", dtype="<f4")
    return want.reshape(stream["nstrands_sent"], stream["nverts"], 3)


def test_library_speaks_the_vectors_format():
    assert codec.format_version() == MANIFEST["format_version"]


@pytest.mark.parametrize("stream", MANIFEST["streams"], ids=lambda s: s["name"])
def test_decodes_vectors_bit_exact(stream):
    with strandcast.Decoder() as dec:
        for f in stream["frames"]:
            data = frame(f["file"])
            header, xyz = dec.decode(data)
            assert xyz.dtype == np.float32
            assert np.array_equal(xyz, positions(f["file"], stream)), f["file"]
            assert header["seq"] == f["seq"] and header["ref_seq"] == f["ref_seq"]
            assert header["keyframe"] is f["keyframe"]
            assert header["sim_time"] == f["sim_time"] and header["sim_step"] == f["sim_step"]
            assert header["head_position"] == pytest.approx(f["head_position"], rel=1e-7, abs=1e-12)
            assert header["head_orientation"] == pytest.approx(f["head_orientation"], rel=1e-7, abs=1e-12)
            assert header["nstrands_total"] == stream["nstrands"]
            assert header["nstrands_sent"] == stream["nstrands_sent"]
            assert header["nverts"] == stream["nverts"] and header["stride"] == stream["stride"]
            assert header["codec_id"] == stream["codec"]
            assert header["max_error_m"] == pytest.approx(stream["max_error_m"], rel=1e-6)
            assert 0 < header["step"] <= 2 * header["max_error_m"]
            assert header["frame_len"] == len(data) == f["bytes"]
            assert dec.header(data) == header


def test_rejects_corrupt_frames():
    stream = MANIFEST["streams"][0]
    key, delta = stream["frames"][0]["file"], stream["frames"][1]["file"]
    with strandcast.Decoder() as dec:
        with pytest.raises(strandcast.DecodeError) as e:
            dec.decode(frame(delta))
        assert e.value.code == "bad_state" and "needs keyframe" in e.value.message

        bad = bytearray(frame(key))
        bad[-5] ^= 0x40
        assert dec.header(bad)["seq"] == stream["frames"][0]["seq"]  # the header is sound
        with pytest.raises(strandcast.DecodeError) as e:
            dec.decode(bad)
        assert e.value.code == "bad_format" and "CRC mismatch" in e.value.message

        with pytest.raises(strandcast.DecodeError) as e:
            dec.decode(frame(key)[:-1])
        assert e.value.code == "bad_format" and "truncated" in e.value.message
        with pytest.raises(strandcast.DecodeError) as e:
            dec.header(b"not a frame at all")
        assert e.value.code == "bad_format"

        # none of that disturbed the decoder: the keyframe and then its delta decode
        dec.decode(frame(key))
        header, xyz = dec.decode(frame(delta))
        assert header["seq"] == stream["frames"][1]["seq"]
        assert np.array_equal(xyz, positions(delta, stream))


def test_closed_decoder_refuses_work():
    dec = strandcast.Decoder()
    dec.close()
    dec.close()
    with pytest.raises(ValueError):
        dec.header(frame(MANIFEST["streams"][0]["frames"][0]["file"]))


def test_library_exports_only_the_abi():
    lib = codec.load_library()
    assert lib.codec_abi_version() == codec.ABI_VERSION
    for internal in ("codec_decode", "codec_core_decode", "codec_encode", "core_fail"):
        with pytest.raises(AttributeError):
            getattr(lib, internal)
