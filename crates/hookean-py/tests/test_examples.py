"""The Python examples of examples/python run as a user runs them: their
output checked against physics (a stiffer cloth sags less), and reruns."""

import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[3]
EXAMPLES = ROOT / "examples" / "python"


def _run(script, *args, cwd=None):
    return subprocess.run([sys.executable, str(EXAMPLES / script), *args],
                          capture_output=True, text=True, cwd=cwd)


def test_the_stiffness_sweep_over_a_process_pool():
    r = _run("sweep_stiffness.py", "--n", "8", "--duration", "0.5", "--stiffness", "1e3", "1e4", "1e5")
    assert r.returncode == 0, r.stderr
    rows = [line.split() for line in r.stdout.splitlines()[1:]]
    assert [float(row[0]) for row in rows] == [1e3, 1e4, 1e5]
    lowest = [float(row[1]) for row in rows]
    # Stiffer springs stretch less under the same weight: the lowest point rises.
    assert lowest[0] < lowest[1] < lowest[2] < 0.0


def test_the_sweep_refuses_zero_workers():
    r = _run("sweep_stiffness.py", "--workers", "0")
    assert r.returncode != 0 and "--workers" in r.stderr


def test_the_matplotlib_drape_reruns_and_keeps_a_users_file(tmp_path):
    pytest.importorskip("matplotlib")
    out = tmp_path / "drape.png"
    for _ in range(2):  # the second run replaces the example's own picture
        r = _run("drape_plot.py", "--n", "8", "--out", str(out))
        assert r.returncode == 0, r.stderr
        assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    mine = tmp_path / "mine.png"
    mine.write_bytes(b"a user's file")
    r = _run("drape_plot.py", "--n", "8", "--out", str(mine))
    assert r.returncode != 0 and "--force" in r.stderr
    assert mine.read_bytes() == b"a user's file"
