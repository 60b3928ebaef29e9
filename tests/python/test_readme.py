"""The README's Python example, as written (the daemon's address aside), against a fresh
strandcastd: it runs and prints what the README shows."""
import os
import re
import subprocess
import sys

import strandcast
from strandcast import codec


def readme_example():
    """The README's only ```python block."""
    blocks = re.findall(r"```python\n(.*?)```", (codec.source_dir() / "README.md").read_text(), re.S)
    assert len(blocks) == 1, "the README should hold one Python example"
    return blocks[0]


def test_readme_example_runs(daemon):
    code = readme_example()
    assert code.count(strandcast.DEFAULT_URL) == 1
    code = code.replace(strandcast.DEFAULT_URL, daemon.url)
    env = dict(os.environ, PYTHONPATH=str(codec.source_dir() / "tests" / "python"))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[0] == "groom 128 x 8"
    assert lines[1] == "refused: out_of_range values.gravity"
    assert len(lines) == 5
    for line in lines[2:]:
        assert re.fullmatch(r"frame \d+ \(128, 8, 3\) finite: True lowest tip: -?\d+\.\d{3} m", line), line
