"""pytest fixtures of the Python client's tests: a strandcastd per test module."""
import pytest

import strandcast


@pytest.fixture(scope="module")
def daemon():
    """A fresh strandcastd (strandcast.Daemon: the C backend, 128 x 8 strands, a free port),
    which must exit 0 on SIGTERM after the module's tests: whatever they sent left it sound."""
    d = strandcast.Daemon()
    yield d
    assert d.stop() == 0, "strandcastd did not exit cleanly"
