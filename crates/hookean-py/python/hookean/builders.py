"""The cloth, rope and jelly (3D lattice) builders with keyword arguments.

Each builder writes a scene file's text from its keyword arguments and
parses it with the facade (:meth:`Scene.from_text`), so the keys, their
defaults and their ranges are the scene file's (``hookean scene-keys``
lists them): ``hookean.cloth(n=32, stiffness=2e4)`` is the scene::

    [cloth]
    n = 32
    stiffness = 2e4

The body's own keys are keyword arguments; the other tables of a scene
(``integrator``, ``solver``, ``model``, ``output``, ``wind`` when the scene
has it) are dicts, and ``colliders`` / ``pins`` lists of dicts (the
``[[collider]]`` and ``[[pin]]`` tables). An unknown key or a value out of
its range raises ``ValueError`` naming it, as in a scene file.

>>> import hookean
>>> sim = hookean.cloth(n=6, duration=0.05, integrator={"h": 0.01}).build()
>>> sim.run_until(0.05) >= 0.05 - 1e-12, sim.positions.shape
(True, (36, 3))
"""

from __future__ import annotations

import json
import math
import numbers

import numpy as np

from ._hookean import Scene

__all__ = ["cloth", "rope", "jelly"]

#: The scene's tables given as dicts, and the arrays of tables given as lists of dicts.
_TABLES = ("integrator", "solver", "model", "output", "wind")
_ARRAYS = {"colliders": "collider", "pins": "pin"}


def _value(v, where):
    """``v`` as a TOML value."""
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        v = float(v)
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)  # a TOML basic string
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x, where) for x in v) + "]"
    raise ValueError(f"{where}: expected a number, string, bool or list, got {type(v).__name__}")


def _table(header, keys, where):
    """The lines of a table, each with the argument it came from."""
    if not isinstance(keys, dict):
        raise ValueError(f"{where}: expected a dict of keys, got {type(keys).__name__}")
    lines = [(header, where)]
    for k, v in keys.items():
        if isinstance(v, dict):  # a sub-table, e.g. solver={"amg": {...}}
            continue
        lines.append((f"{_key(k, where)} = {_value(v, f'{where}.{k}')}", f"{where}.{k}"))
    for k, v in keys.items():
        if isinstance(v, dict):
            name = header.strip("[]") + "." + _key(k, where)
            lines += _table(f"[{name}]", v, f"{where}.{k}")
    return lines


def _key(k, where):
    if not isinstance(k, str) or not k.replace("_", "").isalnum():
        raise ValueError(f"{where}: keys must be names of letters, digits and _, got {k!r}")
    return k


def _scene(body, duration, overrides, keys):
    """The scene of ``body``'s keys, the tables among ``keys`` set apart."""
    tables = {k: keys.pop(k) for k in (*_TABLES, *_ARRAYS) if k in keys}
    parts = []
    if duration is not None:
        parts.append((f"duration = {_value(duration, 'duration')}", "duration"))
    parts += _table(f"[{body}]", keys, body)
    for name in _TABLES:
        if tables.get(name) is not None:
            parts += _table(f"[{name}]", tables[name], name)
    for arg, table in _ARRAYS.items():
        items = tables.get(arg)
        if items is None:
            continue
        if not isinstance(items, (list, tuple)):
            raise ValueError(f"{arg}: expected a list of dicts, got {type(items).__name__}")
        for k, item in enumerate(items):
            parts += _table(f"[[{table}]]", item, f"{arg}[{k}]")
    if isinstance(overrides, str) or not all(isinstance(o, str) for o in overrides):
        raise ValueError("overrides: expected a list of 'key=value' strings")
    origin = f"hookean.{body}()"
    text = "".join(line + "\n" for line, _ in parts)
    try:
        return Scene.from_text(origin, text, list(overrides))
    except ValueError as e:
        raise ValueError(_in_arguments(str(e), origin, parts)) from None


def _in_arguments(message, origin, parts):
    """The facade's ``origin:LINE:COLUMN: ...`` message with the line named
    by the keyword argument that wrote it (the user never saw the text)."""
    head, sep, rest = message.partition(": ")
    fields = head.split(":")
    if sep and fields[0] == origin and len(fields) >= 2 and fields[1].isdigit():
        line = int(fields[1])
        if 1 <= line <= len(parts):
            return f"{parts[line - 1][1]}: {rest}"
    return message


def _builder(body, what):
    def build(*, duration=None, overrides=(), **keys):
        return _scene(body, duration, overrides, keys)

    build.__name__ = build.__qualname__ = body
    build.__doc__ = (
        f"{what} as a :class:`Scene`: the ``[{body}]`` table's keys as keyword\n"
        "    arguments; ``duration`` the scene's length in simulated seconds;\n"
        "    ``integrator``, ``solver``, ``model``, ``output`` and ``wind`` dicts of\n"
        "    their tables; ``colliders`` and ``pins`` lists of dicts; ``overrides``\n"
        "    ``key=value`` strings applied last (as ``Scene.from_file``'s).\n"
    )
    return build


cloth = _builder(
    "cloth",
    "A square cloth (n, size, mass, stiffness, bend_stiffness, damping, pins, plane, origin, ...)",
)
rope = _builder(
    "rope", "A rope (n, length, mass, stiffness, damping, direction, pin_start, pin_end, ...)"
)
jelly = _builder(
    "jelly", "A 3D lattice, a jelly block (n = [nx, ny, nz], spacing, mass, stiffness, damping, origin, ...)"
)
