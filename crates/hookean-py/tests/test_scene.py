"""hookean.Scene and hookean.Simulation against the Rust facade: the same
positions bit for bit as the Rust API (crates/hookean/examples/scene_positions.rs,
which prints each f64 in its shortest round-trip form), the facade's message
for an unknown key, pickling, the OBJ writer that keeps existing files."""

import pathlib
import pickle
import subprocess

import numpy as np
import pytest

import hookean
from conftest import example_bin

ROOT = pathlib.Path(__file__).resolve().parents[3]
DRAPE = str(ROOT / "scenes" / "drape.toml")


def _positions_bin():
    return example_bin("scene_positions", "HOOKEAN_SCENE_POSITIONS_BIN")


@pytest.mark.skipif(
    _positions_bin() is None,
    reason="no scene_positions example (cargo build -p hookean --example scene_positions)",
)
def test_drape_positions_bit_for_bit_as_the_rust_facade():
    out = subprocess.run(
        [_positions_bin(), DRAPE, "0.1", "cloth.n=8"], capture_output=True, text=True, check=True
    ).stdout
    rust = np.array([[float(v) for v in line.split()] for line in out.splitlines()])
    sim = hookean.Scene.from_file(DRAPE, overrides=["cloth.n=8"]).build()
    assert sim.run_until(0.1) == 0.1
    assert sim.positions.shape == (64, 3) == rust.shape
    assert np.array_equal(sim.positions.view(np.uint64), rust.view(np.uint64))
    # The cloth fell: the run did something.
    assert sim.positions[:, 2].min() < -0.01
    assert sim.stats["steps"] == 10


def test_steps_and_state():
    sim = hookean.Scene.from_file(DRAPE, overrides=["cloth.n=4"]).build()
    x0 = sim.positions.copy()
    assert sim.t == 0.0
    assert np.all(sim.velocities == 0.0)
    t = sim.step()
    assert t == sim.t == pytest.approx(0.01)
    assert sim.velocities.shape == (16, 3)
    # Gravity pulls the free particles down (-z).
    assert np.all(sim.positions[:, 2] <= x0[:, 2])
    assert sim.velocities[:, 2].min() < 0.0


def test_run_until_callback_stops_and_raises():
    sim = hookean.Scene.from_file(DRAPE, overrides=["cloth.n=4"]).build()
    seen = []
    t = sim.run_until(1.0, callback=lambda t: seen.append(t) or len(seen) < 3)
    assert len(seen) == 3 and t == seen[-1]

    def boom(t):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="^stop here$"):
        sim.run_until(1.0, callback=boom)
    with pytest.raises(ValueError, match="^t: must be finite and not before"):
        sim.run_until(0.0)


def test_unknown_key_is_the_facades_message():
    with pytest.raises(ValueError, match=r"override cloth\.nn=8: unknown field `nn`"):
        hookean.Scene.from_file(DRAPE, overrides=["cloth.nn=8"])
    with pytest.raises(ValueError, match="cloth.n"):
        hookean.Scene.from_file(DRAPE, overrides=["cloth.n=-3"])
    with pytest.raises(OSError):
        hookean.Scene.from_file(str(ROOT / "scenes" / "no-such-scene.toml"))


def test_pickled_scene_round_trips():
    scene = hookean.Scene.from_file(DRAPE, overrides=["cloth.n=6", "duration=0.05"])
    back = pickle.loads(pickle.dumps(scene))
    assert back.overrides == ["cloth.n=6", "duration=0.05"]
    assert back.text == pathlib.Path(DRAPE).read_text()
    assert back.duration == 0.05
    a, b = scene.build(), back.build()
    a.run_until(0.05)
    b.run_until(0.05)
    assert np.array_equal(a.positions, b.positions)


def test_write_obj_keeps_an_existing_file(tmp_path):
    sim = hookean.Scene.from_file(DRAPE, overrides=["cloth.n=4"]).build()
    path = tmp_path / "frame.obj"
    sim.write_obj(str(path))
    text = path.read_text()
    assert sum(line.startswith("v ") for line in text.splitlines()) == 16
    sim.step()
    with pytest.raises(FileExistsError, match="overwrite=True"):
        sim.write_obj(str(path))
    assert path.read_text() == text
    sim.write_obj(str(path), overwrite=True)
    assert path.read_text() != text
