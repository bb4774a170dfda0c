#!/usr/bin/env python3
"""Build a small test scene in Blender and export it twice: as glTF 2.0 (Blender's own
exporter, `.glb`) and as Mitsuba 3 XML written from the same Blender data (meshes as PLY by
Blender's PLY exporter), for `crates/octolux-io/tests/gltf_scene.rs` (issue 15, item 3).

    python3 -m venv .venv-blender && .venv-blender/bin/pip install bpy==5.0.1
    .venv-blender/bin/python tools/blender/make_gltf_scene.py tests/scenes/gltf

The scene: a closed box room (red and green side walls), a gold metallic sphere (metallic 1,
roughness 0.3), a half-metallic blue cube (metallic 0.5), a cube with a checkerboard base-colour
texture, an emissive panel under the ceiling (an area light) and a point light, seen by one
camera. The XML states what the glTF loader promises (docs in crates/octolux-io/src/gltf_scene.rs):
roughplastic (GGX, alpha = roughness^2, IOR 1.5) for metallic 0, a tinted perfect-mirror
roughconductor for metallic 1, blendbsdf between, all two-sided; point intensity = candela / 683.
Blender's Z-up world becomes Y-up as glTF's exporter makes it: (x, y, z) -> (x, z, -y).
"""
import json
import math
import struct
import sys
from pathlib import Path

import bpy
import mathutils

OUT = Path(sys.argv[1] if len(sys.argv) > 1 else "tests/scenes/gltf").resolve()
OUT.mkdir(parents=True, exist_ok=True)
(OUT / "meshes").mkdir(exist_ok=True)

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene


def material(name, base, metallic=0.0, roughness=0.5, emission=None, image=None):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    p = m.node_tree.nodes["Principled BSDF"]
    p.inputs["Base Color"].default_value = (*base, 1.0)
    p.inputs["Metallic"].default_value = metallic
    p.inputs["Roughness"].default_value = roughness
    if emission is not None:
        p.inputs["Emission Color"].default_value = (*emission[0], 1.0)
        p.inputs["Emission Strength"].default_value = emission[1]
    if image is not None:
        t = m.node_tree.nodes.new("ShaderNodeTexImage")
        t.image = image
        m.node_tree.links.new(t.outputs["Color"], p.inputs["Base Color"])
    m["octolux"] = {"base": list(base), "metallic": metallic, "roughness": roughness,
                    "emission": [c * emission[1] for c in emission[0]] if emission else None,
                    "texture": image.name if image else None}
    return m


def checker(name, n=8, size=64):
    img = bpy.data.images.new(name, size, size, alpha=False)
    px = []
    for y in range(size):
        for x in range(size):
            v = 0.8 if ((x * n // size) + (y * n // size)) % 2 == 0 else 0.1
            px += [v, v * 0.6, 0.2, 1.0]
    img.pixels = px
    img.filepath_raw = str(OUT / f"{name}.png")
    img.file_format = "PNG"
    img.save()
    return img


def add(obj, mat):
    obj.data.materials.append(mat)
    return obj


def plane(name, loc, rot, size, mat):
    bpy.ops.mesh.primitive_plane_add(size=size, location=loc, rotation=rot)
    o = bpy.context.active_object
    o.name = name
    return add(o, mat)


white = material("white", (0.7, 0.7, 0.7))
red = material("red", (0.6, 0.05, 0.05))
green = material("green", (0.1, 0.5, 0.1))
gold = material("gold", (0.9, 0.7, 0.3), metallic=1.0, roughness=0.3)
blue = material("blue", (0.2, 0.3, 0.8), metallic=0.5, roughness=0.4)
tex = material("checker", (1.0, 1.0, 1.0), image=checker("checker"))
lamp = material("lamp", (0.0, 0.0, 0.0), emission=((1.0, 0.9, 0.8), 12.0))

h = math.pi / 2
plane("floor", (0, 0, 0), (0, 0, 0), 4, white)
plane("ceiling", (0, 0, 4), (math.pi, 0, 0), 4, white)
plane("back", (0, 2, 2), (h, 0, 0), 4, white)
plane("left", (-2, 0, 2), (0, h, 0), 4, red)
plane("right", (2, 0, 2), (0, -h, 0), 4, green)
plane("front", (0, -2, 2), (-h, 0, 0), 4, white)
plane("panel", (0, 0, 3.95), (math.pi, 0, 0), 1.0, lamp)
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(-0.8, 0.5, 0.7), segments=48, ring_count=24)
s = bpy.context.active_object
s.name = "sphere"
bpy.ops.object.shade_smooth()
add(s, gold)
bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.9, 0.6, 0.5), rotation=(0, 0, 0.4))
bpy.context.active_object.name = "cube"
add(bpy.context.active_object, blue)
bpy.ops.mesh.primitive_cube_add(size=0.8, location=(0.6, -0.7, 0.4), rotation=(0, 0, -0.3))
bpy.context.active_object.name = "textured"
add(bpy.context.active_object, tex)

bpy.ops.object.light_add(type="POINT", location=(1.2, -1.0, 3.0))
light = bpy.context.active_object
light.name = "point"
light.data.energy = 60.0
light.data.shadow_soft_size = 0.0

bpy.ops.object.camera_add(location=(0, -1.95, 2.0))
cam = bpy.context.active_object
cam.name = "camera"
cam.rotation_euler = (math.radians(88), 0, 0)
cam.data.sensor_fit = "VERTICAL"
cam.data.angle_y = math.radians(70)
scene.camera = cam
scene.render.resolution_x, scene.render.resolution_y = 160, 120
bpy.context.view_layer.update()

bpy.ops.export_scene.gltf(filepath=str(OUT / "scene.glb"), export_format="GLB", export_lights=True, export_cameras=True,
                          export_yup=True, export_apply=True, export_import_convert_lighting_mode="SPEC")

# --- the same scene as Mitsuba 3 XML ---------------------------------------------------------
ZUP_TO_YUP = mathutils.Matrix(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, 0), (0, 0, 0, 1)))


def fmt(m):
    return " ".join(f"{m[r][c]:.9g}" for r in range(4) for c in range(4))


def bsdf(mat):
    o = mat["octolux"].to_dict()
    a = o["roughness"] ** 2
    if o["texture"]:
        base = f'<texture type="bitmap" name="diffuse_reflectance"><string name="filename" value="{o["texture"]}.png"/></texture>'
    else:
        base = '<rgb name="diffuse_reflectance" value="{:.6g} {:.6g} {:.6g}"/>'.format(*o["base"])
    plastic = (f'<bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" value="{a:.6g}"/>'
               f'<float name="int_ior" value="1.5"/><float name="ext_ior" value="1.0"/>{base}</bsdf>')
    metal = ('<bsdf type="roughconductor"><string name="distribution" value="ggx"/><float name="alpha" value="{:.6g}"/>'
             '<string name="material" value="none"/><rgb name="specular_reflectance" value="{:.6g} {:.6g} {:.6g}"/></bsdf>'
             ).format(a, *o["base"])
    m = o["metallic"]
    inner = plastic if m <= 0 else metal if m >= 1 else (
        f'<bsdf type="blendbsdf"><float name="weight" value="{m:.6g}"/>{plastic}{metal}</bsdf>')
    return f'<bsdf type="twosided">{inner}</bsdf>', o["emission"]


gltf = json.loads((lambda b: b[20:20 + struct.unpack("<I", b[12:16])[0]])((OUT / "scene.glb").read_bytes()))
candela = gltf["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"]

parts = ['<scene version="3.0.0">', '<integrator type="path"><integer name="max_depth" value="-1"/></integrator>']
cw = ZUP_TO_YUP @ cam.matrix_world @ mathutils.Matrix.Diagonal((-1, 1, -1, 1))
parts.append(f'<sensor type="perspective"><string name="fov_axis" value="y"/><float name="fov" value="{math.degrees(cam.data.angle_y):.9g}"/>'
             f'<transform name="to_world"><matrix value="{fmt(cw)}"/></transform>'
             f'<film type="hdrfilm"><integer name="width" value="640"/><integer name="height" value="480"/><rfilter type="tent"/></film></sensor>')
for o in scene.objects:
    if o.type != "MESH":
        continue
    bpy.ops.object.select_all(action="DESELECT")
    o.select_set(True)
    bpy.context.view_layer.objects.active = o
    ply = OUT / "meshes" / f"{o.name}.ply"
    # Blender's PLY exporter averages normals at shared vertices: flat-shaded objects go
    # without normals and are marked face_normals (glTF's exporter splits their vertices)
    smooth = o.name == "sphere"
    bpy.ops.wm.ply_export(filepath=str(ply), export_selected_objects=True, apply_modifiers=True, export_normals=smooth,
                          export_uv=True, export_colors="NONE", ascii_format=False, forward_axis="Y", up_axis="Z")
    b, emission = bsdf(o.data.materials[0])
    em = ('<emitter type="area"><rgb name="radiance" value="{:.6g} {:.6g} {:.6g}"/></emitter>'.format(*emission)) if emission else ""
    parts.append(f'<shape type="ply"><string name="filename" value="meshes/{o.name}.ply"/>'
                 f'<boolean name="face_normals" value="{str(not smooth).lower()}"/>'
                 f'<transform name="to_world"><matrix value="{fmt(ZUP_TO_YUP)}"/></transform>{b}{em}</shape>')
p = ZUP_TO_YUP @ light.matrix_world.translation
col = [c * candela / 683.0 for c in light.data.color]
parts.append('<emitter type="point"><point name="position" x="{:.9g}" y="{:.9g}" z="{:.9g}"/>'
             '<rgb name="intensity" value="{:.6g} {:.6g} {:.6g}"/></emitter>'.format(p.x, p.y, p.z, *col))
parts.append("</scene>")
(OUT / "scene.xml").write_text("\n".join(parts) + "\n")
print("wrote", OUT / "scene.glb", OUT / "scene.xml", f"(point light {candela:.6g} cd)")
