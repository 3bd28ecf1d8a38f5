"""Materials made by hand in Blender (its own node API, not our importer), exported and rendered.

    blender -b --factory-startup --python-exit-code 1 -P make_materials.py -- \
        --scripts BLENDER_DIR --out OUT_DIR [--only NAME ...]

BLENDER_DIR holds the repository's blender/ scripts (export_material.py, render_socket.py,
import_material.py, compat_noise.py); in the 4.3 chroot, copy them and this script under
/srv/trixie/tmp first. Runs in Blender 3.4 and 4.x; each builds the materials as a user of
that version would (4.x: Noise Texture with noise types; 3.x: Musgrave Texture). A
material's name is NAME in 4.x and NAME_b34 when made in 3.4. For each material:

1. build it with bpy (nodes, values, links as in the UI), on a plane, and save
   OUT_DIR/<material>.blend (compressed; nothing else in the file);
2. export it the way a user would: `blender -b <material>.blend -P export_material.py --
   -o OUT_DIR/<material>.json` (a separate Blender, so the .blend is what is exported);
3. render its four Principled BSDF maps (Base Color, Metallic, Roughness, Normal) from the
   hand-made material itself, point-sampled as blender/render_socket.py does (that script's
   scene and Emission wiring), to OUT_DIR/<material>/hand-<version>-<map>.exr.

tests/reference/nodes/gen_roundtrip.py makes node-reference cases blender_made_<material>_<map>
from the exported JSON (rendered by render_node_references.py through import_material), and
tests/unit/test_blender_made.c compares our evaluation of the exported JSON with the
renders of step 3: what Blender computes for the material as it was made, not as we
rebuilt it.

Texture vectors left unlinked read Generated coordinates, raw (unsnapped), as in a real
material: discontinuous maps may flip a pixel or two (see gen_roundtrip.py).
"""

import argparse
import os
import subprocess
import sys

import bpy

MAPS = (("basecolor", "Base Color"), ("metallic", "Metallic"),
        ("roughness", "Roughness"), ("normal", "Normal"))


def major():
    return bpy.app.version[0]


def new_material(name):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    tree = mat.node_tree
    bsdf = tree.nodes["Principled BSDF"]
    return mat, tree, bsdf


def link(tree, a, b):
    tree.links.new(a, b)


def noise_ramp_bump(name):
    """Noise (Generated, unlinked) -> Color Ramp -> Base Color; Map Range -> Roughness;
    Greater Than -> Metallic; the noise as a Bump height."""
    mat, t, bsdf = new_material(name)
    noise = t.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 4.0
    noise.inputs["Detail"].default_value = 4.0
    noise.inputs["Roughness"].default_value = 0.55
    noise.inputs["Distortion"].default_value = 0.2
    ramp = t.nodes.new("ShaderNodeValToRGB")
    els = ramp.color_ramp.elements
    els[0].position, els[0].color = 0.35, (0.05, 0.1, 0.3, 1.0)
    els[1].position, els[1].color = 0.65, (0.8, 0.6, 0.3, 1.0)
    mid = els.new(0.5)
    mid.color = (0.2, 0.5, 0.2, 1.0)
    link(t, noise.outputs["Fac"], ramp.inputs["Fac"])
    link(t, ramp.outputs["Color"], bsdf.inputs["Base Color"])
    mr = t.nodes.new("ShaderNodeMapRange")
    mr.inputs["To Min"].default_value = 0.25
    mr.inputs["To Max"].default_value = 0.75
    link(t, noise.outputs["Fac"], mr.inputs["Value"])
    link(t, mr.outputs["Result"], bsdf.inputs["Roughness"])
    gt = t.nodes.new("ShaderNodeMath")
    gt.operation = "GREATER_THAN"
    gt.inputs[1].default_value = 0.6
    link(t, noise.outputs["Fac"], gt.inputs[0])
    link(t, gt.outputs["Value"], bsdf.inputs["Metallic"])
    bump = t.nodes.new("ShaderNodeBump")
    bump.inputs["Strength"].default_value = 0.6
    bump.inputs["Distance"].default_value = 0.05
    link(t, noise.outputs["Fac"], bump.inputs["Height"])
    link(t, bump.outputs["Normal"], bsdf.inputs["Normal"])
    return mat


def voronoi_math_mix(name):
    """Voronoi F1 on Object coordinates; Distance ^ 0.6 mixes the cell colour with a cream;
    1 - that is the Roughness, Distance < 0.15 the Metallic, and it drives a Bump."""
    mat, t, bsdf = new_material(name)
    tc = t.nodes.new("ShaderNodeTexCoord")
    vor = t.nodes.new("ShaderNodeTexVoronoi")
    vor.inputs["Scale"].default_value = 6.0
    vor.inputs["Randomness"].default_value = 0.85
    link(t, tc.outputs["Object"], vor.inputs["Vector"])
    pw = t.nodes.new("ShaderNodeMath")
    pw.operation = "POWER"
    pw.inputs[1].default_value = 0.6
    link(t, vor.outputs["Distance"], pw.inputs[0])
    mix = t.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.blend_type = "MIX"
    link(t, pw.outputs["Value"], mix.inputs["Factor"])
    link(t, vor.outputs["Color"], mix.inputs[6])          # A (colour)
    mix.inputs[7].default_value = (0.9, 0.85, 0.7, 1.0)  # B (colour)
    link(t, mix.outputs[2], bsdf.inputs["Base Color"])    # Result (colour)
    inv = t.nodes.new("ShaderNodeMath")
    inv.operation = "SUBTRACT"
    inv.use_clamp = True
    inv.inputs[0].default_value = 1.0
    link(t, pw.outputs["Value"], inv.inputs[1])
    link(t, inv.outputs["Value"], bsdf.inputs["Roughness"])
    lt = t.nodes.new("ShaderNodeMath")
    lt.operation = "LESS_THAN"
    lt.inputs[1].default_value = 0.15
    link(t, vor.outputs["Distance"], lt.inputs[0])
    link(t, lt.outputs["Value"], bsdf.inputs["Metallic"])
    bump = t.nodes.new("ShaderNodeBump")
    bump.inputs["Strength"].default_value = 0.4
    bump.inputs["Distance"].default_value = 0.02
    link(t, pw.outputs["Value"], bump.inputs["Height"])
    link(t, bump.outputs["Normal"], bsdf.inputs["Normal"])
    return mat


def _fractal(t, kind, scale, detail4, offset, gain=None):
    """A 4.x Noise Texture of noise type `kind` (Roughness 0.5, Lacunarity 2), or the 3.x
    Musgrave Texture a 3.4 user would pick for it (Detail + 1, Dimension 1)."""
    if major() >= 4:
        n = t.nodes.new("ShaderNodeTexNoise")
        n.noise_type = kind
        n.normalize = False
        n.inputs["Detail"].default_value = detail4
        n.inputs["Roughness"].default_value = 0.5
        n.inputs["Lacunarity"].default_value = 2.0
    else:
        n = t.nodes.new("ShaderNodeTexMusgrave")
        n.musgrave_type = kind
        n.inputs["Detail"].default_value = detail4 + 1.0
        n.inputs["Dimension"].default_value = 1.0
        n.inputs["Lacunarity"].default_value = 2.0
    n.inputs["Scale"].default_value = scale
    n.inputs["Offset"].default_value = offset
    if gain is not None:  # 4.x finds no unavailable socket by name (Hetero Terrain's Gain)
        n.inputs["Gain"].default_value = gain
    return n


def mapping_noise_types(name):
    """Generated -> Mapping (moved, turned, stretched) -> Ridged Multifractal -> Map Range ->
    Color Ramp (Base Color), Multiply Add (Roughness), Greater Than (Metallic); a Hetero
    Terrain of the same coordinates as the Bump height."""
    mat, t, bsdf = new_material(name)
    tc = t.nodes.new("ShaderNodeTexCoord")
    mp = t.nodes.new("ShaderNodeMapping")
    mp.inputs["Location"].default_value = (0.3, -0.2, 0.0)
    mp.inputs["Rotation"].default_value = (0.0, 0.0, 0.6)
    mp.inputs["Scale"].default_value = (2.5, 4.0, 1.0)
    link(t, tc.outputs["Generated"], mp.inputs["Vector"])
    ridged = _fractal(t, "RIDGED_MULTIFRACTAL", 1.5, 5.0, 1.0, 2.0)
    link(t, mp.outputs["Vector"], ridged.inputs["Vector"])
    mr = t.nodes.new("ShaderNodeMapRange")
    mr.inputs["From Max"].default_value = 3.0
    link(t, ridged.outputs["Fac"], mr.inputs["Value"])
    ramp = t.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.interpolation = "EASE"
    els = ramp.color_ramp.elements
    els[0].position, els[0].color = 0.2, (0.3, 0.05, 0.02, 1.0)
    els[1].position, els[1].color = 0.8, (0.95, 0.9, 0.6, 1.0)
    link(t, mr.outputs["Result"], ramp.inputs["Fac"])
    link(t, ramp.outputs["Color"], bsdf.inputs["Base Color"])
    ma = t.nodes.new("ShaderNodeMath")
    ma.operation = "MULTIPLY_ADD"
    ma.inputs[1].default_value = 0.5
    ma.inputs[2].default_value = 0.2
    link(t, mr.outputs["Result"], ma.inputs[0])
    link(t, ma.outputs["Value"], bsdf.inputs["Roughness"])
    gt = t.nodes.new("ShaderNodeMath")
    gt.operation = "GREATER_THAN"
    gt.inputs[1].default_value = 0.55
    link(t, mr.outputs["Result"], gt.inputs[0])
    link(t, gt.outputs["Value"], bsdf.inputs["Metallic"])
    hetero = _fractal(t, "HETERO_TERRAIN", 3.0, 3.0, 0.5)
    link(t, mp.outputs["Vector"], hetero.inputs["Vector"])
    bump = t.nodes.new("ShaderNodeBump")
    bump.inputs["Strength"].default_value = 0.3
    bump.inputs["Distance"].default_value = 0.02
    link(t, hetero.outputs["Fac"], bump.inputs["Height"])
    link(t, bump.outputs["Normal"], bsdf.inputs["Normal"])
    return mat


MATERIALS = (("noise_ramp_bump", noise_ramp_bump), ("voronoi_math_mix", voronoi_math_mix),
             ("mapping_noise_types", mapping_noise_types))


def clear_file():
    for coll in (bpy.data.objects, bpy.data.meshes, bpy.data.materials, bpy.data.lights,
                 bpy.data.cameras, bpy.data.node_groups, bpy.data.worlds, bpy.data.images):
        for block in list(coll):
            coll.remove(block)


def save_blend(mat, path):
    mesh = bpy.data.meshes.new("Plane")
    mesh.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    mesh.materials.append(mat)
    ob = bpy.data.objects.new("Plane", mesh)
    bpy.context.scene.collection.objects.link(ob)
    tmp = path[:-len(".blend")] + ".tmp.blend"
    bpy.ops.wm.save_as_mainfile(filepath=tmp, compress=True, copy=True)
    os.replace(tmp, path)


def export_blend(scripts, blend, out_json):
    cmd = [bpy.app.binary_path, "-b", "--factory-startup", blend, "--python-exit-code", "1",
           "-P", os.path.join(scripts, "export_material.py"), "--", "-o", out_json]
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                       universal_newlines=True)
    if p.returncode != 0 or not os.path.exists(out_json):
        raise RuntimeError("%s: export failed (exit %d):\n%s" % (blend, p.returncode, p.stdout))


def render_maps(rs, mat, name, out_dir):
    scene = bpy.context.scene
    plane = rs.setup_scene(scene)
    os.makedirs(os.path.join(out_dir, name), exist_ok=True)
    version = "%d.%d" % bpy.app.version[:2]
    for tag, socket in MAPS:
        ref = "Principled BSDF:" + socket
        m = mat.copy()
        rs.wire_emission(m, ref, name)
        scene.render.stamp_note_text = "%s; hand-made material %s; socket %s" % (
            rs.version_note(), name, ref)
        plane.data.materials.clear()
        plane.data.materials.append(m)
        out = os.path.join(out_dir, name, "hand-%s-%s.exr" % (version, tag))
        scene.render.filepath = out + ".tmp.exr"
        bpy.ops.render.render(write_still=True)
        os.replace(out + ".tmp.exr", out)
        print("make_materials: %s" % out, flush=True)


def main(argv):
    ap = argparse.ArgumentParser(prog="make_materials.py")
    ap.add_argument("--scripts", required=True, help="the repository's blender/ directory")
    ap.add_argument("--out", required=True, help="where .blend, .json and EXRs go")
    ap.add_argument("--only", nargs="*", help="material base names")
    a = ap.parse_args(argv)
    scripts = os.path.abspath(a.scripts)
    out_dir = os.path.abspath(a.out)
    sys.path.insert(0, scripts)
    import render_socket as rs  # noqa: E402 (needs bpy, and scripts on the path)
    suffix = "" if major() >= 4 else "_b34"
    for base, make in MATERIALS:
        if a.only and base not in a.only:
            continue
        name = base + suffix
        clear_file()
        mat = make(name)
        blend = os.path.join(out_dir, name + ".blend")
        save_blend(mat, blend)
        export_blend(scripts, blend, os.path.join(out_dir, name + ".json"))
        render_maps(rs, mat, name, out_dir)
    return 0


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    sys.exit(main(args))
