# Renders loom's fitted maps with Blender's Cycles under each of an eval report's renderer views
# (REPORT/renderer/views.json) and compares every texel with loom's own rendering of the same
# view (fitting/report/renderer_views.h), as web/render-check.mjs does for three.js. Two materials:
#
# - built natively from `loom export --mtlx`'s textures (the default): a Diffuse BSDF (a_d) added
#   to an Anisotropic GGX BSDF whose colour is a_s · F0 (specular_color.png times the F0 that the
#   document's specular_IOR carries), its roughness, anisotropy and rotation turned from Standard
#   Surface's parameters into Cycles' (α_x = r² / (1 + k), α_y = r² (1 + k) for anisotropy k < 0
#   along the tangent: k = √(1 − a) − 1; the rotation's sense reversed, since the document's
#   follows MaterialX's rotate3d), and the tangent-space normal map. That is loom's model but for
#   the lobe (GGX for Ward, fitting/report/mtlx_export.h) and F0 taken as Schlick's at normal
#   incidence. Blender 3.4's glTF importer cannot carry that: it reads no KHR_materials_anisotropy.
# - `--gltf`: the report's glTF (REPORT/material) as Blender's glTF importer builds it, a
#   Principled BSDF, as a user who imports it gets it (KHR_materials_specular turned into
#   Principled's Specular and Specular Tint; no anisotropy; the diffuse under the specular layer).
#   Its textures are read texel for texel (closest), as the other renderers' are.
#
# Each view: the maps on a flat quad at z = 0 in the sample frame (metres), a point light of
# radius 0, an orthographic camera along the view direction, no world light. Every sample of a
# pixel then sees the same light and nothing else, so a few samples (4, the default) give what
# 64 give: they only average the pixel's footprint. Cycles' unit of light power is measured
# first: a Lambertian white plane 1 m under a 1 W point light. Each texel's radiance is read at
# its centre's projection into the render.
#
#   blender -b --factory-startup --python-exit-code 1 --python blender/render_check.py -- \
#       REPORT [MTLX_DIR] [--gltf] [--max-mean-difference D] [--samples N]
# MTLX_DIR defaults to REPORT/mtlx, which `loom eval` writes. Writes REPORT/renderer/cycles-VIEW.f32
# (as loom's), cycles-VIEW.png (at the view's white, as loom's PNG) and cycles-comparison.json
# (with --gltf: cycles-gltf-VIEW.* and cycles-gltf-comparison.json); `node web/renderers-page.mjs
# REPORT` then shows every renderer beside loom.
import json
import math
import os
import re
import struct
import sys

import bpy
import numpy
from mathutils import Vector

# Debian 12's Blender 3.4 glTF importer still spells numpy's bool `numpy.bool`, an alias that
# Debian 12's numpy 1.24 removed.
if "bool" not in numpy.__dict__:
    numpy.bool = bool


def parse_arguments(argv):
    options = {"max_mean_difference": math.inf, "samples": 4, "paths": [], "gltf": False}
    i = 0
    while i < len(argv):
        if argv[i] == "--gltf":
            options["gltf"] = True
        elif argv[i] == "--max-mean-difference":
            options["max_mean_difference"] = float(argv[i + 1])
            i += 1
        elif argv[i] == "--samples":
            options["samples"] = int(argv[i + 1])
            i += 1
        else:
            options["paths"].append(argv[i])
        i += 1
    if len(options["paths"]) == 1:
        options["paths"].append(os.path.join(options["paths"][0], "mtlx"))
    if len(options["paths"]) != 2:
        raise SystemExit("usage: render_check.py -- REPORT [MTLX_DIR] [--gltf] [--max-mean-difference D] [--samples N]")
    return options


def new_scene(resolution, samples):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.cycles.filter_width = 0.01  # each pixel its own radiance, not its neighbours'
    scene.render.resolution_x = scene.render.resolution_y = resolution
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    world = bpy.data.worlds.new("dark")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0
    scene.world = world
    return scene


def quad(name, half_width, half_height, material):
    """The maps' quad in the sample frame: u along +x (the image's columns), v up the image (−y)."""
    mesh = bpy.data.meshes.new(name)
    corners = [(-half_width, -half_height, 0), (half_width, -half_height, 0), (half_width, half_height, 0),
               (-half_width, half_height, 0)]
    mesh.from_pydata(corners, [], [(0, 1, 2, 3)])
    uv = mesh.uv_layers.new(name="UVMap")
    for loop, (u, v) in zip(mesh.loops, [(0, 1), (1, 1), (1, 0), (0, 0)]):
        uv.data[loop.index].uv = (u, v)
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def point_light(position, watts):
    data = bpy.data.lights.new("light", "POINT")
    data.energy = watts
    data.shadow_soft_size = 0
    obj = bpy.data.objects.new("light", data)
    obj.location = position
    bpy.context.scene.collection.objects.link(obj)
    return obj


def camera(direction, scale):
    data = bpy.data.cameras.new("camera")
    data.type = "ORTHO"
    data.ortho_scale = scale
    data.clip_start, data.clip_end = 0.001, 10
    obj = bpy.data.objects.new("camera", data)
    obj.location = Vector(direction).normalized() * 1.0
    up = "Y" if abs(Vector(direction).normalized().z) < 0.99 else "Y"
    obj.rotation_euler = (-Vector(direction)).to_track_quat("-Z", up).to_euler()
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.scene.camera = obj
    return obj


def render(scene, path):
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(path)
    image.colorspace_settings.name = "Non-Color"
    pixels = list(image.pixels[:])
    size = image.size[0]
    bpy.data.images.remove(image)
    return pixels, size


def radiance_at(pixels, size, cam, point):
    """Bilinear RGB at `point`'s projection (Blender's pixel rows run from the bottom)."""
    local = cam.matrix_world.inverted() @ Vector(point)
    scale = cam.data.ortho_scale
    column = (local.x / scale + 0.5) * size - 0.5
    row = (local.y / scale + 0.5) * size - 0.5
    c0, r0 = int(math.floor(column)), int(math.floor(row))
    fc, fr = column - c0, row - r0
    rgb = [0.0, 0.0, 0.0]
    for dr, wr in ((0, 1 - fr), (1, fr)):
        for dc, wc in ((0, 1 - fc), (1, fc)):
            r = min(max(r0 + dr, 0), size - 1)
            c = min(max(c0 + dc, 0), size - 1)
            for k in range(3):
                rgb[k] += wr * wc * pixels[4 * (r * size + c) + k]
    return rgb


def white_plane_material():
    material = bpy.data.materials.new("white")
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (1, 1, 1, 1)
    output = nodes.new("ShaderNodeOutputMaterial")
    links.new(diffuse.outputs["BSDF"], output.inputs["Surface"])
    return material


def watt_intensity(samples, work):
    """Cycles' radiant intensity (W/sr) of a 1 W point light: a white Lambertian plane 1 m under
    it shows radiance I / π at the centre."""
    scene = new_scene(32, samples)
    quad("plane", 0.05, 0.05, white_plane_material())
    point_light((0, 0, 1), 1.0)
    cam = camera((0, 0, 1), 0.1)
    pixels, size = render(scene, os.path.join(work, "cycles-unit.exr"))
    return math.pi * radiance_at(pixels, size, cam, (0, 0, 0))[0]


def f0_of_document(mtlx_dir):
    with open(os.path.join(mtlx_dir, "material.mtlx")) as f:
        ior = float(re.search(r'name="specular_IOR" type="float" value="([0-9.eE+-]+)"', f.read()).group(1))
    return ((ior - 1) / (ior + 1)) ** 2


def loom_material(mtlx_dir):
    material = bpy.data.materials.new("loom")
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()

    def texture(name, colorspace):
        node = nodes.new("ShaderNodeTexImage")
        node.image = bpy.data.images.load(os.path.join(mtlx_dir, name + ".png"))
        node.image.colorspace_settings.name = colorspace
        node.interpolation = "Closest"  # a texel is one pixel of the maps
        return node

    def math_node(operation, a, b=None):
        node = nodes.new("ShaderNodeMath")
        node.operation = operation
        for i, value in enumerate((a, b)):
            if value is None:
                continue
            if isinstance(value, (int, float)):
                node.inputs[i].default_value = value
            else:
                links.new(value, node.inputs[i])
        return node.outputs[0]

    base = texture("base_color", "sRGB")
    tint = texture("specular_color", "sRGB")
    roughness = texture("roughness", "Non-Color")
    anisotropy = texture("anisotropy", "Non-Color")
    rotation = texture("rotation", "Non-Color")
    normal_texture = texture("normal", "Non-Color")
    normal = nodes.new("ShaderNodeNormalMap")
    normal.space = "TANGENT"
    normal.uv_map = "UVMap"
    links.new(normal_texture.outputs["Color"], normal.inputs["Color"])
    tangent = nodes.new("ShaderNodeTangent")
    tangent.direction_type = "UV_MAP"
    tangent.uv_map = "UVMap"

    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    links.new(base.outputs["Color"], diffuse.inputs["Color"])
    links.new(normal.outputs["Normal"], diffuse.inputs["Normal"])

    specular_color = nodes.new("ShaderNodeMixRGB")
    specular_color.blend_type = "MULTIPLY"
    specular_color.inputs["Fac"].default_value = 1
    links.new(tint.outputs["Color"], specular_color.inputs["Color1"])
    f0 = f0_of_document(mtlx_dir)
    specular_color.inputs["Color2"].default_value = (f0, f0, f0, 1)

    glossy = nodes.new("ShaderNodeBsdfAnisotropic")
    glossy.distribution = "GGX"
    links.new(specular_color.outputs["Color"], glossy.inputs["Color"])
    links.new(roughness.outputs["Color"], glossy.inputs["Roughness"])
    k = math_node("SUBTRACT", math_node("SQRT", math_node("SUBTRACT", 1.0, anisotropy.outputs["Color"])), 1.0)
    links.new(k, glossy.inputs["Anisotropy"])
    # The document's rotation turns clockwise about the normal, as MaterialX's rotate3d does;
    # Cycles' turns the other way: 1 − r is −r in turns.
    links.new(math_node("SUBTRACT", 1.0, rotation.outputs["Color"]), glossy.inputs["Rotation"])
    links.new(normal.outputs["Normal"], glossy.inputs["Normal"])
    links.new(tangent.outputs["Tangent"], glossy.inputs["Tangent"])

    add = nodes.new("ShaderNodeAddShader")
    links.new(diffuse.outputs["BSDF"], add.inputs[0])
    links.new(glossy.outputs["BSDF"], add.inputs[1])
    output = nodes.new("ShaderNodeOutputMaterial")
    links.new(add.outputs["Shader"], output.inputs["Surface"])
    return material


def imported_gltf(path):
    """The glTF's quad and material as Blender's importer makes them (glTF's y up becomes
    Blender's z up: the sample frame in metres), its textures read texel for texel."""
    bpy.ops.import_scene.gltf(filepath=path)
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    if len(meshes) != 1:
        raise RuntimeError("%s: %d meshes imported, expected the sample's quad" % (path, len(meshes)))
    for material in meshes[0].data.materials:
        for node in material.node_tree.nodes:
            if node.type == "TEX_IMAGE":
                node.interpolation = "Closest"
    return meshes[0]


def srgb(linear):
    v = min(max(linear, 0.0), 1.0)
    return 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055


def write_png(path, rgb, width, height, white):
    """`rgb` row by row from the maps' first row, as loom writes its PNG (white = the view's white)."""
    image = bpy.data.images.new("png", width, height, alpha=False)
    pixels = [0.0] * (4 * width * height)
    for y in range(height):
        for x in range(width):
            source, target = 3 * (y * width + x), 4 * ((height - 1 - y) * width + x)  # Blender's rows from the bottom
            for k in range(3):
                pixels[target + k] = srgb(rgb[source + k] / white)
            pixels[target + 3] = 1.0
    image.pixels[:] = pixels
    image.filepath_raw = path
    image.file_format = "PNG"
    image.save()
    bpy.data.images.remove(image)


def read_f32(path):
    with open(path, "rb") as f:
        data = f.read()
    return struct.unpack("<%df" % (len(data) // 4), data)


def main():
    options = parse_arguments(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
    report, mtlx_dir = options["paths"]
    renderer_dir = os.path.join(report, "renderer")
    with open(os.path.join(renderer_dir, "views.json")) as f:
        views = json.load(f)
    width, height, pixel_m = views["width"], views["height"], views["pixel_mm"] / 1000
    unit = watt_intensity(options["samples"], renderer_dir)
    resolution = min(max(8 * max(width, height), 64), 1024)
    prefix = "cycles-gltf" if options["gltf"] else "cycles"
    results = []
    for view in views["views"]:
        scene = new_scene(resolution, options["samples"])
        if options["gltf"]:
            imported_gltf(os.path.join(report, "material", "material.gltf"))
        else:
            quad("maps", width * pixel_m / 2, height * pixel_m / 2, loom_material(mtlx_dir))
        # loom's intensity is per mm² at the sample; in metres it is 10⁻⁶ of that.
        point_light([c / 1000 for c in view["light_mm"]], view["intensity"] * 1e-6 / unit)
        cam = camera(view["view"], 1.05 * math.hypot(width, height) * pixel_m)
        pixels, size = render(scene, os.path.join(renderer_dir, "%s-%s.exr" % (prefix, view["name"])))
        cycles = []
        for y in range(height):
            for x in range(width):
                centre = ((x + 0.5 - width / 2) * pixel_m, (y + 0.5 - height / 2) * pixel_m, 0)
                cycles.extend(radiance_at(pixels, size, cam, centre))
        loom = read_f32(os.path.join(renderer_dir, view["loom"]))
        with open(os.path.join(renderer_dir, "%s-%s.f32" % (prefix, view["name"])), "wb") as f:
            f.write(struct.pack("<%df" % len(cycles), *cycles))
        write_png(os.path.join(renderer_dir, "%s-%s.png" % (prefix, view["name"])), cycles, width, height, view["white"])
        difference = sum(abs(a - b) for a, b in zip(cycles, loom)) / sum(abs(b) for b in loom)
        results.append({"name": view["name"], "relative_difference": difference,
                        "mean_loom": sum(loom) / len(loom), "mean_cycles": sum(cycles) / len(cycles)})
        print("%s: relative difference %.4f" % (view["name"], difference))
    mean = sum(r["relative_difference"] for r in results) / len(results)
    check = {"blender": bpy.app.version_string, "samples": options["samples"], "watt_intensity_w_per_sr": unit,
             "material": "the glTF, imported" if options["gltf"] else "built from the MaterialX textures",
             "results": results, "mean_relative_difference": mean}
    with open(os.path.join(renderer_dir, prefix + "-comparison.json"), "w") as f:
        json.dump(check, f, indent=2)
    print("mean relative difference %.4f (Blender %s, Cycles, %s)" % (mean, bpy.app.version_string, check["material"]))
    if not mean <= options["max_mean_difference"]:
        raise RuntimeError("mean relative difference %.4f > --max-mean-difference %g" % (mean, options["max_mean_difference"]))


main()
