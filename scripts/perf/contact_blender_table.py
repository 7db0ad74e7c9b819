# Blender's cloth (implicit mass-spring, its own collision) on cloth-table's
# setup: a 64 x 64 cloth, 1 m, 1 kg, dropped from 0.7 m onto data/table.obj
# and a floor, 2 s at 400 steps (25 frames/s x 8 steps per frame, h = 5 ms),
# springs of 1e4 N/m (Blender's k = stiffness / mean spring length), bend
# springs of 1e3 N/m, no air drag.
# With PARAMS = blender, the cloth keeps Blender's default material instead
# (0.3 kg per vertex, tension 15, air drag 1: a heavy, soft cloth).
# Usage: blender -b --factory-startup -P scripts/perf/contact_blender_table.py -- TABLE_OBJ collide|free THREADS hookean|blender
import bpy, sys, time
argv = sys.argv[sys.argv.index("--") + 1:]
table_obj, mode, threads, params = argv[0], argv[1], int(argv[2]), argv[3]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.threads_mode = 'FIXED'
scene.render.threads = threads
scene.render.fps = 25
scene.frame_start, scene.frame_end = 1, 51
# A 64 x 64 vertex grid, 1 m square, corner at (-0.5, -0.5, 0.7).
bpy.ops.mesh.primitive_grid_add(x_subdivisions=63, y_subdivisions=63, size=1.0, location=(0, 0, 0.7))
cloth = bpy.context.active_object
nv = len(cloth.data.vertices)
if nv != 4096:
    bpy.ops.object.delete()
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=64, y_subdivisions=64, size=1.0, location=(0, 0, 0.7))
    cloth = bpy.context.active_object
    nv = len(cloth.data.vertices)
mod = cloth.modifiers.new("Cloth", 'CLOTH')
s = mod.settings
s.quality = 8
if params == "hookean":
    s.air_damping = 0.0
    spring = 1.0 / (64 - 1)
    s.tension_stiffness = s.compression_stiffness = s.shear_stiffness = 1e4 * spring
    s.bending_model = 'LINEAR'
    s.bending_stiffness = 1e3 * spring
    s.mass = 1.0 / nv
s.use_internal_springs = False
s.use_pressure = False
c = mod.collision_settings
c.use_self_collision = False
c.use_collision = (mode == "collide")
c.distance_min = 0.005
mod.point_cache.frame_start, mod.point_cache.frame_end = 1, 51
if mode == "collide":
    bpy.ops.wm.obj_import(filepath=table_obj, forward_axis='Y', up_axis='Z')
    table = bpy.context.selected_objects[0]
    table.modifiers.new("Collision", 'COLLISION')
    table.collision.thickness_outer = 0.005
    table.collision.cloth_friction = 5.0
    bpy.ops.mesh.primitive_plane_add(size=4.0, location=(0, 0, 0))
    floor = bpy.context.active_object
    floor.modifiers.new("Collision", 'COLLISION')
t0 = time.perf_counter()
for f in range(1, 52):
    scene.frame_set(f)
wall = time.perf_counter() - t0
dg = bpy.context.evaluated_depsgraph_get()
ev = cloth.evaluated_get(dg)
zs = [(ev.matrix_world @ v.co).z for v in ev.data.vertices]
print("BLENDER %s %s vertices %d wall_s %.3f min_z %.4f max_z %.4f" % (params, mode, nv, wall, min(zs), max(zs)))
