"""Builds a small scene in Blender and exports it with Blender's own glTF exporter, for
tests/tests/blender.rs: a glass sphere (transmission, IOR, an absorbing volume, spindle's
scattering extras) over a diffuse floor, a camera and a point light.

Run headless: blender -b --factory-startup --python glass_scene.py -- OUT.glb OUT.json
OUT.json records what the script set, in Blender's coordinates (z up), for the test to check
the import against.
"""

import json
import math
import sys

import bpy
from mathutils import Vector

out_glb, out_json = sys.argv[sys.argv.index("--") + 1:][:2]

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.resolution_x = 160
scene.render.resolution_y = 120
scene.render.pixel_aspect_x = 1.0
scene.render.pixel_aspect_y = 1.0

# The glass sphere.
centre = (0.5, 0.3, 1.25)
radius = 1.0
bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=radius, location=centre)
sphere = bpy.context.active_object
sphere.name = "Glass"
bpy.ops.object.shade_smooth()
glass = bpy.data.materials.new("Glass")
glass.use_nodes = True
nodes, links = glass.node_tree.nodes, glass.node_tree.links
bsdf = nodes["Principled BSDF"]
bsdf.inputs["Base Color"].default_value = (1.0, 1.0, 1.0, 1.0)
bsdf.inputs["Metallic"].default_value = 0.0
bsdf.inputs["Transmission"].default_value = 1.0
ior = 1.45
bsdf.inputs["IOR"].default_value = ior
# KHR_materials_volume: a Volume Absorption node on the output's Volume socket (colour,
# density = 1 / attenuation distance), and a thickness on the exporter's node group.
absorption = nodes.new("ShaderNodeVolumeAbsorption")
attenuation_colour = (0.8, 0.6, 0.4)
density = 0.5
absorption.inputs["Color"].default_value = (*attenuation_colour, 1.0)
absorption.inputs["Density"].default_value = density
links.new(absorption.outputs["Volume"], nodes["Material Output"].inputs["Volume"])
group = bpy.data.node_groups.new("glTF Material Output", "ShaderNodeTree")
group.inputs.new("NodeSocketFloat", "Thickness")
settings = nodes.new("ShaderNodeGroup")
settings.node_tree = group
settings.inputs["Thickness"].default_value = 1.0
albedo = [0.9, 0.85, 0.8]
phase_g = 0.25
glass["spindle_albedo"] = albedo
glass["spindle_phase_g"] = phase_g
sphere.data.materials.append(glass)

# The floor.
bpy.ops.mesh.primitive_plane_add(size=8.0, location=(0.0, 0.0, 0.0))
floor = bpy.context.active_object
floor.name = "Floor"
floor_colour = (0.7, 0.6, 0.5)
paint = bpy.data.materials.new("Floor")
paint.use_nodes = True
paint_bsdf = paint.node_tree.nodes["Principled BSDF"]
paint_bsdf.inputs["Base Color"].default_value = (*floor_colour, 1.0)
paint_bsdf.inputs["Metallic"].default_value = 0.0
floor.data.materials.append(paint)

# The camera, aimed at the sphere's centre, 40° vertically.
camera_data = bpy.data.cameras.new("Lens")
camera_data.sensor_fit = "VERTICAL"
camera_data.angle = math.radians(40.0)
camera = bpy.data.objects.new("Camera", camera_data)
scene.collection.objects.link(camera)
camera.location = (1.5, -6.0, 2.5)
aim = Vector(centre) - camera.location
camera.rotation_mode = "QUATERNION"
camera.rotation_quaternion = aim.to_track_quat("-Z", "Y")
scene.camera = camera

# The point light.
lamp_data = bpy.data.lights.new("Lamp", type="POINT")
lamp_data.energy = 800.0
lamp_data.color = (1.0, 0.9, 0.8)
lamp = bpy.data.objects.new("Lamp", lamp_data)
scene.collection.objects.link(lamp)
lamp.location = (2.0, -3.0, 4.0)

bpy.context.view_layer.update()
world = camera.matrix_world
bpy.ops.export_scene.gltf(
    filepath=out_glb,
    export_format="GLB",
    export_cameras=True,
    export_lights=True,
    export_extras=True,
    export_yup=True,
)

with open(out_json, "w") as f:
    json.dump(
        {
            "sphere": {"centre": list(centre), "radius": radius},
            "glass": {
                "ior": ior,
                "attenuation_colour": list(attenuation_colour),
                "density": density,
                "albedo": albedo,
                "phase_g": phase_g,
            },
            "floor": {"colour": list(floor_colour), "size": 8.0},
            "camera": {
                "location": list(camera.location),
                "right": list(world.col[0].xyz.normalized()),
                "up": list(world.col[1].xyz.normalized()),
                "fov_y": camera_data.angle,
                "aspect": 160 / 120,
            },
            "lamp": {
                "location": list(lamp.location),
                "power": lamp_data.energy,
                "colour": list(lamp_data.color),
            },
        },
        f,
        indent=1,
    )
