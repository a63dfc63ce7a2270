"""Renders an exported glTF sphere with Blender's Cycles in the twin's sphere scene.

Run by blender_test.cpp as
    blender -b --factory-startup --python blender_render.py -- \
        SPHERE.gltf OUT.txt SIZE RADIUS_PX LIGHT_THETA LIGHT_PHI ENV_LEVEL SAMPLES

The scene is the twin's (twin/rendering.md): an orthographic camera looking down -z at the
unit sphere, image right +x and up +y (Blender's world axes here), a point-like key light
(a sun of angle 0) at LIGHT_THETA degrees from the view direction and azimuth LIGHT_PHI in
the image plane, and a uniform environment. Units: the twin's pixel is pi * radiance / E, so
the sun's strength (its irradiance E, W/m^2) is pi and the world's radiance is ENV_LEVEL.
Writes the linear Rec.709 (= linear sRGB) RGB of every pixel, row 0 at the top, one pixel a
line.
"""
import math
import sys

import bpy
import mathutils
import numpy

# Debian 12's Blender 3.4 glTF importer still uses numpy.bool, an alias numpy 1.24 (Debian 12's)
# removed; the alias was the builtin bool.
if not hasattr(numpy, "bool"):
    numpy.bool = bool

args = sys.argv[sys.argv.index("--") + 1:]
gltf, out_path = args[0], args[1]
size, radius_px = int(args[2]), float(args[3])
light_theta, light_phi = math.radians(float(args[4])), math.radians(float(args[5]))
env_level, samples = float(args[6]), int(args[7])

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=gltf)
scene = bpy.context.scene

cam_data = bpy.data.cameras.new("camera")
cam_data.type = "ORTHO"
cam_data.ortho_scale = size / radius_px  # radius_px pixels per unit
cam = bpy.data.objects.new("camera", cam_data)
cam.location = (0.0, 0.0, 10.0)  # looking down -z, up +y: the default orientation
scene.collection.objects.link(cam)
scene.camera = cam

sun_data = bpy.data.lights.new("key", type="SUN")
sun_data.energy = math.pi
sun_data.angle = 0.0
sun = bpy.data.objects.new("key", sun_data)
toward = mathutils.Vector((math.sin(light_theta) * math.cos(light_phi),
                           math.sin(light_theta) * math.sin(light_phi), math.cos(light_theta)))
sun.rotation_euler = toward.to_track_quat("Z", "Y").to_euler()  # the sun shines along its -z
scene.collection.objects.link(sun)

world = bpy.data.worlds.new("world")
world.use_nodes = True
bg = world.node_tree.nodes["Background"]
bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
bg.inputs["Strength"].default_value = env_level
scene.world = world

scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = samples
scene.cycles.use_denoising = False
scene.cycles.use_adaptive_sampling = False
scene.cycles.seed = 1
scene.cycles.max_bounces = 4
scene.render.threads_mode = "FIXED"
scene.render.threads = 2
scene.render.resolution_x = size
scene.render.resolution_y = size
scene.render.resolution_percentage = 100
scene.render.film_transparent = False
scene.render.filter_size = 0.01  # one sample position per pixel area, as the twin's pixel centre
scene.view_settings.view_transform = "Standard"
scene.view_settings.look = "None"
scene.view_settings.exposure = 0.0
scene.view_settings.gamma = 1.0
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "32"
exr = out_path + ".exr"
scene.render.filepath = exr
bpy.ops.render.render(write_still=True)

img = bpy.data.images.load(exr)
px = list(img.pixels)  # RGBA floats, row 0 at the bottom, linear (EXR is not display-encoded)
with open(out_path, "w") as f:
    for y in range(size - 1, -1, -1):
        for x in range(size):
            i = 4 * (y * size + x)
            f.write("%.7g %.7g %.7g\n" % (px[i], px[i + 1], px[i + 2]))
