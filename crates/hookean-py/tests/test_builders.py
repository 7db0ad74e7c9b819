"""hookean.cloth / rope / jelly: the builders' scenes against the shipped
scene files they restate (the same positions, bit for bit), and their
refusals naming the key."""

import pathlib
import pickle

import numpy as np
import pytest

import hookean

ROOT = pathlib.Path(__file__).resolve().parents[3]
SCENES = ROOT / "scenes"


def _run(scene, t):
    sim = scene.build()
    sim.run_until(t)
    return sim.positions


def _same_bits(a, b):
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


def test_cloth_is_the_drape_of_the_scene_file():
    # drape.toml holds every key at its default: cloth(n=8) is it with cloth.n=8.
    built = _run(hookean.cloth(n=8, duration=5.0), 0.1)
    filed = _run(hookean.Scene.from_file(str(SCENES / "drape.toml"), overrides=["cloth.n=8"]), 0.1)
    assert _same_bits(built, filed)
    assert built[:, 2].min() < -0.01  # it fell


def _max_stretch(x, n):
    """The largest length over rest length of the cloth's grid edges."""
    g = x.reshape(n, n, 3)
    edges = np.concatenate([
        np.linalg.norm(g[1:] - g[:-1], axis=2).ravel(),
        np.linalg.norm(g[:, 1:] - g[:, :-1], axis=2).ravel(),
    ])
    return edges.max() * (n - 1)  # rest length 1 / (n - 1) on a 1 m cloth


def test_a_changed_key_changes_the_run():
    soft = _max_stretch(_run(hookean.cloth(n=8, stiffness=1e3), 0.2), 8)
    stiff = _max_stretch(_run(hookean.cloth(n=8, stiffness=1e5), 0.2), 8)
    # Under the same weight, springs 100 times softer stretch more.
    assert soft > stiff > 1.0


def test_rope_restates_rope_toml():
    built = hookean.rope(
        duration=5.0, n=20, length=1.0, mass=1.0, stiffness=1e4, damping=0.1,
        direction=[1.0, 0.0, 0.0], pin_start=True, pin_end=False,
        integrator={"method": "implicit-euler", "h": 0.01},
        solver={"newton_rtol": 1e-6, "forcing": 0.02},
    )
    filed = hookean.Scene.from_file(str(SCENES / "rope.toml"))
    assert _same_bits(_run(built, 0.2), _run(filed, 0.2))


def test_jelly_with_a_collider_list_restates_jelly_toml():
    built = hookean.jelly(
        duration=3.0, n=[6, 6, 6], spacing=0.05, mass=1.0, stiffness=1e3, damping=0.1,
        origin=np.array([0.0, 0.0, 0.5]),
        integrator={"method": "implicit-euler", "h": 0.005},
        colliders=[{"kind": "plane", "point": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 1.0]}],
        solver={"newton_rtol": 1e-6, "forcing": 0.02},
    )
    filed = hookean.Scene.from_file(str(SCENES / "jelly.toml"))
    assert _same_bits(_run(built, 0.05), _run(filed, 0.05))


def test_overrides_apply_last_and_the_scene_pickles():
    scene = hookean.cloth(n=8, overrides=["cloth.n=4"])
    assert scene.build().positions.shape == (16, 3)
    again = pickle.loads(pickle.dumps(scene))
    assert _same_bits(_run(again, 0.05), _run(scene, 0.05))


def test_sub_tables():
    scene = hookean.cloth(n=8, solver={"preconditioner": "amg", "amg": {"sweeps": 2}})
    assert "[solver.amg]" in scene.text and "sweeps = 2" in scene.text
    assert _run(scene, 0.02).shape == (64, 3)


@pytest.mark.parametrize(
    "kwargs, named",
    [
        (dict(nn=8), "nn"),
        (dict(n=1), "cloth.n"),
        (dict(n=8, integrator={"hh": 0.01}), "hh"),
        (dict(n=8, integrator={"h": -1.0}), "integrator.h"),
        (dict(n=8, pins=3), "pins"),
        (dict(n=8, colliders={"kind": "plane"}), "colliders"),
        (dict(n=8, colliders=[{"kind": "cube"}]), "kind"),
        (dict(n=8, integrator="bdf"), "integrator"),
        (dict(n=object()), "cloth.n"),
        (dict(n=8, overrides="cloth.n=4"), "overrides"),
    ],
)
def test_bad_keys_raise_value_error_naming_them(kwargs, named):
    with pytest.raises(ValueError, match=named.replace(".", r"\.")):
        hookean.cloth(**kwargs).build()
