#!/usr/bin/env python3
"""Writes crates/hookean/src/scene_keys.txt, the listing `hookean scene-keys`
prints, from the field docs of the scene tables in crates/hookean/src/scene/
(their one owner). Run it after changing a scene key; the test
`scene::tests::the_key_listing_names_every_key` fails until you do."""
import re, pathlib, textwrap
root = pathlib.Path(__file__).resolve().parent.parent
src = "".join((root / "crates/hookean/src/scene" / f).read_text()
              for f in ("mod.rs", "model.rs", "solver.rs", "output.rs"))
tables = {"Scene": "", "ClothScene": "cloth", "RopeScene": "rope", "JellyScene": "jelly",
          "TutorialScene": "tutorial", "ModelScene": "model", "IntegratorScene": "integrator",
          "SolverScene": "solver", "AmgScene": "solver.amg", "FilterScene": "filter",
          "OutputScene": "output", "MeshScene": "mesh", "ContactScene": "contact"}
# AUTO_AMG_PARTICLES is hookean-sparse's AUTO_AMG_BLOCKS (one particle, one block).
any_rs = (root / "crates/hookean-sparse/src/precond/any.rs").read_text()
auto_amg = re.search(r"AUTO_AMG_BLOCKS: usize = ([0-9_]+);", any_rs).group(1).replace("_", " ")
lines = ["Scene keys (TOML; `hookean run SCENE --set key=value` overrides one).",
         "A scene has exactly one model table: [cloth], [rope], [jelly], [mesh], [particle] or [tutorial].",
         "[[collider]] tables: kind = \"plane\" (point, normal, margin), \"sphere\" (center, radius, margin)",
         "or \"mesh\" (path, scale = 1, offset = [0, 0, 0], thickness = 0.005 m, velocity = [0, 0, 0] m/s,",
         "angular_velocity = [0, 0, 0] rad/s, pivot = centre of its box); every kind also static_friction",
         "(default 0) and kinetic_friction (default: static_friction). docs/CONTACT.md explains them.",
         "Units are SI (m, kg, s, N/m, N s/m). Generated from crates/hookean/src/scene/ by scripts/scene-keys.py.",
         ""]
for name, table in tables.items():
    body = re.search(r"pub struct " + name + r" \{(.*?)\n\}", src, re.S).group(1)
    doc, rename = [], None
    if table:
        lines.append(f"[{table}]")
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
            wrapped = textwrap.wrap(text, 78) or [""]
            lines.append(f"  {key}")
            lines += ["      " + w for w in wrapped]
            doc = []
        elif not l.startswith("#"):
            doc = []
    lines.append("")
(root / "crates/hookean/src/scene_keys.txt").write_text("\n".join(lines))
