"""Render one socket of a graph, per pixel, as Blender computes it (runs inside Blender).

    blender -b --factory-startup --python-exit-code 1 -P blender/render_socket.py -- jobs.json

jobs.json: {"jobs": [{"graph": ".../graph.json", "socket": "NODE:SOCKET",
                      "out": ".../blender-3.4.exr"}, ...],
            "results": ".../results.json",            (optional: where to report failures)
            "check_only": false}                      (true: build, do not render)

For each job: build the material (import_material.build_material), feed the socket's value
into an Emission shader (strength 1) wired to the Material Output, and render the scene's
plane with the orthographic camera at 128 x 128, 1 sample, a 0.01 px Blackman-Harris
filter, no light, a black world, to a float32 RGB ZIP EXR. The film then holds, per pixel,
the socket's value at (within 0.005 px of) the pixel centre; casekit's graphs snap their
coordinates so that offset does not matter.

The socket is looked up as sg_compile does: an output socket of the node with that
identifier, else an input socket (its link's source, or its unlinked value; an unlinked
input without a value of its own, such as Normal or a texture's Vector, reads what Cycles
uses instead: the shading normal, Generated coordinates). A float
socket arrives as (v, v, v), a vector as (x, y, z), a colour as (r, g, b).

What Cycles writes, measured in 3.4 and 4.3 (see the project report / casekit cases):
- Non-finite sample components are written as 0 (film: ensure_finite), and a pixel whose
  |R| + |G| + |B| overflows to inf is written as (0, 0, 0) (the sample clamp at FLT_MAX).
- Negative values pass unchanged (emission is not clamped at 0).
- Row 0 of the EXR is the top of the image (+y of the plane).

The Blender version, the graph's SHA-256 and the socket are written into the EXR header
(the stamp "Note" field, header attribute "Note"), so every reference says what made it
and from what. Outputs are rendered to a
temporary file and renamed.
"""

import hashlib
import json
import os
import sys
import traceback

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
if HERE not in sys.path:
    sys.path.insert(0, HERE)
import import_material as im  # noqa: E402

RES = 128


def version_note():
    return "Blender %s (%s %s); imsynth blender/render_socket.py" % (
        bpy.app.version_string, bpy.app.build_hash.decode() if isinstance(
            bpy.app.build_hash, bytes) else bpy.app.build_hash,
        bpy.app.build_date.decode() if isinstance(bpy.app.build_date, bytes)
        else bpy.app.build_date)


def setup_scene(scene):
    im.build_scene(scene, None, res=RES, light=False, world_color=0.0, samples=1,
                   filter_width=0.01)
    r = scene.render
    for attr in dir(r):
        if attr.startswith("use_stamp") and attr != "use_stamp_note":
            try:
                setattr(r, attr, False)
            except (AttributeError, TypeError):
                pass
    r.use_stamp_note = True
    r.stamp_note_text = version_note()
    r.use_stamp = False  # metadata only; never burn text into pixels
    im.set_exr_output(scene, "//unused.exr")
    return scene.objects["Plane"]


def clear_data():
    for m in list(bpy.data.materials):
        bpy.data.materials.remove(m)
    for g in list(bpy.data.node_groups):
        bpy.data.node_groups.remove(g)


def _socket_value_source(mat, ref, source):
    """(output socket to link from, or None, constant value or None)."""
    if ":" not in ref:
        raise im.ImportError_("%s: socket %r is not NODE:SOCKET" % (source, ref))
    node_name, ident = ref.rsplit(":", 1)
    tree = mat.node_tree
    node = tree.nodes.get(node_name)
    if node is None:
        raise im.ImportError_("%s: socket %r: no node named %r" % (source, ref, node_name))
    by_name = node.bl_idname in ("ShaderNodeGroup", "NodeGroupInput", "NodeGroupOutput")
    out = im._find_socket(node.outputs, ident, by_name)
    if out is not None:
        if out.type == "SHADER":
            raise im.ImportError_("%s: socket %r is a shader socket" % (source, ref))
        return out, None
    inp = im._find_socket(node.inputs, ident, by_name)
    if inp is None:
        raise im.ImportError_("%s: socket %r: node %r has no socket %r in Blender %s"
                              % (source, ref, node_name, ident, bpy.app.version_string))
    if inp.type == "SHADER":
        raise im.ImportError_("%s: socket %r is a shader socket" % (source, ref))
    if inp.is_linked:
        return inp.links[0].from_socket, None
    if inp.hide_value:
        return _implicit_source(tree, node, inp, source, ref), None
    v = inp.default_value
    if hasattr(v, "__len__"):
        v = list(v)[:3]
    else:
        v = [float(v)] * 3
    return None, v


def _implicit_source(tree, node, inp, source, ref):
    """The value Cycles uses for an unlinked input that has no value of its own
    (hide_value): the shading normal for normal inputs, Generated coordinates for a
    texture's Vector (what shadergraph's SG_IMPLICIT_NORMAL / SG_IMPLICIT_GENERATED mean).
    Blender's default_value of such a socket is meaningless (0, 0, 0)."""
    if inp.type == "VECTOR" and "Normal" in inp.name:
        geo = tree.nodes.new("ShaderNodeNewGeometry")
        geo.name = "imsynth implicit Normal"
        return geo.outputs["Normal"]
    if inp.type == "VECTOR" and inp.name == "Vector" and node.bl_idname.startswith("ShaderNodeTex"):
        tc = tree.nodes.new("ShaderNodeTexCoord")
        tc.name = "imsynth implicit Generated"
        return tc.outputs["Generated"]
    raise im.ImportError_("%s: socket %r: unlinked input without a value of its own, and "
                          "no rule for what Cycles uses there" % (source, ref))


def wire_emission(mat, ref, source):
    tree = mat.node_tree
    from_socket, const = _socket_value_source(mat, ref, source)
    outs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"]
    if not outs:
        raise im.ImportError_("%s: no Material Output" % source)
    for n in outs:
        n.is_active_output = False
    out = outs[0]
    out.is_active_output = True
    out.target = "ALL"
    for s in out.inputs:
        for l in list(s.links):
            tree.links.remove(l)
    em = tree.nodes.new("ShaderNodeEmission")
    em.name = "imsynth Emission"
    em.location = (out.location[0], out.location[1] - 300.0)
    em.inputs["Strength"].default_value = 1.0
    if from_socket is not None:
        tree.links.new(from_socket, em.inputs["Color"])
    else:
        em.inputs["Color"].default_value = const + [1.0]
    tree.links.new(em.outputs["Emission"], out.inputs["Surface"])


def render_job(scene, plane, job, check_only=False):
    source = job["graph"]
    with open(source, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()
    # The header says what made the image and from which graph, so a reference whose
    # graph.json changed later is recognisably stale (render_node_references.py checks).
    scene.render.stamp_note_text = "%s; graph sha256 %s; socket %s" % (
        version_note(), digest, job["socket"])
    clear_data()
    data = im.load_json(source)
    warnings = []
    mat = im.build_material(data, im.blender_major(), source=source, warnings=warnings)
    wire_emission(mat, job["socket"], source)
    if check_only:
        return warnings
    plane.data.materials.clear()
    plane.data.materials.append(mat)
    out = job["out"]
    tmp = out + ".tmp.exr"
    scene.render.filepath = tmp
    bpy.ops.render.render(write_still=True)
    if not os.path.exists(tmp):
        raise RuntimeError("%s: Blender wrote no image to %s" % (source, tmp))
    os.replace(tmp, out)
    return warnings


def main(argv):
    if len(argv) != 1:
        print("usage: blender -b -P render_socket.py -- jobs.json", file=sys.stderr)
        return 2
    with open(argv[0]) as f:
        spec = json.load(f)
    scene = bpy.context.scene
    plane = setup_scene(scene)
    failures, warnings = [], []
    for job in spec["jobs"]:
        try:
            for w in render_job(scene, plane, job, spec.get("check_only", False)):
                warnings.append({"graph": job["graph"], "warning": w})
            print("render_socket: ok %s -> %s" % (job["socket"], job["out"]), flush=True)
        except Exception as e:  # one bad case must not stop the batch
            msg = str(e) if isinstance(e, im.ImportError_) else traceback.format_exc()
            failures.append({"graph": job["graph"], "error": msg})
            print("render_socket: FAILED %s: %s" % (job["graph"], msg), file=sys.stderr,
                  flush=True)
    if spec.get("results"):
        with open(spec["results"], "w") as f:
            json.dump({"version": bpy.app.version_string, "failures": failures,
                       "warnings": warnings}, f, indent=1)
    return 1 if failures else 0


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    sys.exit(main(args))
