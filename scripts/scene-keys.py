#!/usr/bin/env python3
"""Writes the scene-key listings from the field docs of the scene tables
(their one owner): crates/hookean/src/scene_keys.txt, the facade's keys
(crates/hookean/src/scene/), and crates/hookean-cli/src/scene_keys.txt, the
listing `hookean scene-keys` prints: the facade's keys and the `hookean`
program's (crates/hookean-cli/src/scene.rs) merged table by table. Run it
after changing a scene key; the tests `scene::tests::the_key_listing_names_every_key`
(facade) and `scene::tests::the_key_listing_names_every_key_of_both` (CLI)
fail until you do."""
import re, pathlib, textwrap
root = pathlib.Path(__file__).resolve().parent.parent
facade_src = "".join((root / "crates/hookean/src/scene" / f).read_text()
                     for f in ("mod.rs", "model.rs", "solver.rs", "output.rs", "pins.rs"))
cli_src = (root / "crates/hookean-cli/src/scene.rs").read_text()
# (table, its structs): the facade's, then where the program's join them.
facade = [("", ["Scene"]), ("cloth", ["ClothScene"]), ("rope", ["RopeScene"]),
          ("jelly", ["JellyScene"]), ("model", ["ModelScene"]),
          ("integrator", ["IntegratorScene"]), ("solver", ["SolverScene"]),
          ("solver.amg", ["AmgScene"]), ("filter", ["FilterScene"]),
          ("output", ["OutputScene"]), ("mesh", ["MeshScene"]), ("contact", ["ContactScene"]), ("wind", ["WindScene"]),
          ("pin", ["PinGroupScene"]), ("pin.keys", ["KeyScene"])]
# Arrays of tables: one [[pin]] table per group, its keys an array of inline tables.
array_tables = {"pin": "[[pin]] (one table per pin group; docs/CONTACT.md, \"Pins as handles\")",
                "pin.keys": "pin.keys = [{ t, translation, rotation }, ...] (the path's keys)"}
program = {"": ["ProgramKeys"], "output": ["PictureScene"]}
merged = []
for table, structs in facade:
    merged.append((table, structs + program.get(table, [])))
    if table == "jelly":
        merged.append(("tutorial", ["TutorialScene"]))
# AUTO_AMG_PARTICLES is hookean-sparse's AUTO_AMG_BLOCKS (one particle, one block).
any_rs = (root / "crates/hookean-sparse/src/precond/any.rs").read_text()
auto_amg = re.search(r"AUTO_AMG_BLOCKS: usize = ([0-9_]+);", any_rs).group(1).replace("_", " ")
colliders = [
    "[[collider]] tables: kind = \"plane\" (point, normal, margin), \"sphere\" (center, radius, margin)",
    "or \"mesh\" (path, scale = 1, offset = [0, 0, 0], thickness = 0.005 m in [0, the diagonal of",
    "the mesh's box], velocity = [0, 0, 0] m/s, angular_velocity = [0, 0, 0] rad/s, pivot = centre of",
    "its box; or keys = [{ t s, translation m, rotation rad }, ...] with interpolation = \"linear\" or",
    "\"smooth\", a keyframed path; or frames = [OBJ files of frames 1, 2, ...] of path's topology,",
    "frame_interval = 0.04 s in (0, inf), a deforming body; one motion per collider); every kind also",
    "static_friction (default 0) and kinetic_friction (default:",
    "static_friction). No particle may start inside a collider. docs/CONTACT.md explains them."]


def entries(src, name, table, seen, program_words):
    """The listing lines of struct `name`'s fields (keys of `table`)."""
    body = re.search(r"pub struct " + name + r" \{(.*?)\n\}", src, re.S).group(1)
    doc, rename, lines = [], None, []
    in_attribute = False  # inside a #[serde(...)] spread over several lines
    for raw in body.split("\n"):
        l = raw.strip()
        if in_attribute:
            in_attribute = not l.endswith(")]")
            if "rename = " in l:
                rename = re.search(r'rename = "([^"]+)"', l).group(1)
            continue
        if l.startswith("#[") and not l.endswith("]"):
            in_attribute = True
            continue
        if l.startswith("///"):
            doc.append(l[3:].strip())
        elif l.startswith("#[serde(") and "rename = " in l:
            rename = re.search(r'rename = "([^"]+)"', l).group(1)
        elif l.startswith("pub ") and ":" in l:
            key = (table + "." if table else "") + (rename or l[4:].split(":")[0])
            rename = None
            text = " ".join(doc).replace("`", "")
            text = re.sub(r"\[([^\]]+)\]\([^)]*\)", r"\1", text)
            text = text.replace("[AUTO_AMG_PARTICLES]", auto_amg)
            text = text.replace("[Scene::build_within]", "Scene::build_within")
            if program_words:  # the program's name for the facade's memory cap
                text = text.replace("the memory cap of Scene::build_within", "the --max-memory cap")
            doc = []
            if key in seen:  # a table both own ([output]) is listed once
                continue
            seen.add(key)
            lines.append(f"  {key}")
            lines += ["      " + w for w in textwrap.wrap(text, 78) or [""]]
        elif not l.startswith("#"):
            doc = []
    return lines


def listing(header, tables, src, program_words):
    lines, seen = header + [""], set()
    for table, structs in tables:
        if table:
            lines.append(array_tables.get(table, f"[{table}]"))
        for name in structs:
            lines += entries(src, name, table, seen, program_words)
        lines.append("")
    return "\n".join(lines)


(root / "crates/hookean/src/scene_keys.txt").write_text(listing(
    ["Keys of the facade's scene tables (TOML; Scene::with_overrides sets one by key=value).",
     "A scene has exactly one model table: [cloth], [rope], [jelly], [mesh] or [particle], or one",
     "of a program's own (SceneExtension; a program may add keys to these tables too)."]
    + colliders
    + ["Units are SI (m, kg, s, N/m, N s/m). Generated from crates/hookean/src/scene/ by scripts/scene-keys.py."],
    facade, facade_src, False))
(root / "crates/hookean-cli/src/scene_keys.txt").write_text(listing(
    ["Scene keys (TOML; `hookean run SCENE --set key=value` overrides one).",
     "A scene has exactly one model table: [cloth], [rope], [jelly], [mesh], [particle] or [tutorial]."]
    + colliders
    + ["Units are SI (m, kg, s, N/m, N s/m). Generated from crates/hookean/src/scene/ and",
       "crates/hookean-cli/src/scene.rs by scripts/scene-keys.py."],
    merged, facade_src + cli_src, True))
