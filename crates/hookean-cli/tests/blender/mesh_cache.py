"""Plays a hookean point cache in Blender, headless, as a user would load it
(docs/OUTPUTS.md, "Point caches"): imports the rest mesh cache-rest.obj with
forward Y and up Z (hookean's z is up, so no axis change), adds a Mesh Cache
modifier on the cache, and prints the evaluated vertex positions at the
given scene frames, one JSON line per frame:
{"frame": F, "x": [x0, y0, z0, x1, ...]}.

blender -b --factory-startup --python mesh_cache.py -- REST.obj CACHE FORMAT F1 F2 ...
"""
import json
import sys

import bpy

args = sys.argv[sys.argv.index("--") + 1:]
rest, cache, fmt, frames = args[0], args[1], args[2], [int(f) for f in args[3:]]

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.wm.obj_import(filepath=rest, forward_axis="Y", up_axis="Z")
obj = bpy.context.selected_objects[0]
mod = obj.modifiers.new("hookean", "MESH_CACHE")
mod.cache_format = fmt
mod.filepath = cache
mod.interpolation = "NONE"
mod.time_mode = "FRAME"
mod.play_mode = "SCENE"
mod.frame_start = 0.0
mod.forward_axis = "POS_Y"
mod.up_axis = "POS_Z"

scene = bpy.context.scene
for f in frames:
    scene.frame_set(f)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    mesh = obj.evaluated_get(depsgraph).to_mesh()
    x = [c for v in mesh.vertices for c in v.co]
    print("HOOKEAN-FRAME " + json.dumps({"frame": f, "x": x}))
    sys.stdout.flush()
