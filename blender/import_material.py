"""Build a Blender material (and optionally the project's scene) from our graph JSON.

Runs inside Blender 3.4 or 4.x:

    blender -b -P blender/import_material.py -- material.json --save out.blend [--scene]
        [--scene-file assets/scene-flash.json]

and is a module for the other scripts here (render_socket.py):

    import import_material as im
    mat = im.build_material(json_dict, im.blender_major(), source="material.json")
    im.build_scene(bpy.context.scene, mat)

The JSON is FORMAT.md's imsynth-graph/1, in Blender 4.x vocabulary. What differs in 3.x:
- Node groups: 3.x declares interface sockets with tree.inputs/outputs.new, 4.x with
  tree.interface.new_socket.
- Principled BSDF: socket identifiers were renamed in 4.0; we map the ones whose meaning
  did not change (Base Color, Metallic, Roughness, Normal, IOR, Alpha) and refuse the
  rest. An unset IOR is set to 4.x's default 1.5 (3.4's default is 1.45).
- Noise Texture: 4.x's noise types (and unnormalized fBM) are 3.x Musgrave nodes;
  blender/compat_noise.py:noise_node_for_blender3 translates or refuses.
Every error names the JSON file and the node (or group / link) at fault.
"""

import json
import os
import struct
import sys

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
if HERE not in sys.path:
    sys.path.insert(0, HERE)

FORMAT = "imsynth-graph/1"

# Principled BSDF inputs whose identifier and meaning are the same in 3.x and 4.x.
PRINCIPLED_COMMON = ("Base Color", "Metallic", "Roughness", "Normal", "IOR", "Alpha")
PRINCIPLED_4X_IOR_DEFAULT = 1.5

SOCKET_TYPES = {"FLOAT": "NodeSocketFloat", "VECTOR": "NodeSocketVector",
                "RGBA": "NodeSocketColor", "SHADER": "NodeSocketShader",
                "INT": "NodeSocketInt", "BOOLEAN": "NodeSocketBool"}


class ImportError_(Exception):
    """A graph this Blender cannot build; the message names file and place."""


def blender_major():
    return bpy.app.version[0]


def _fail(source, where, msg):
    raise ImportError_("%s: %s: %s" % (source, where, msg))


def _noise_for_blender3(node, linked_inputs, linked_outputs, source, where):
    try:
        from compat_noise import noise_node_for_blender3
    except ImportError as e:
        _fail(source, where, "Blender 3.x needs blender/compat_noise.py to translate a "
              "Noise Texture, and it cannot be imported (%s)" % e)
    try:
        return noise_node_for_blender3(node, linked_inputs, linked_outputs)
    except ValueError as e:
        _fail(source, where, str(e))


def _find_socket(sockets, key, by_name):
    for s in sockets:
        if (s.name if by_name else s.identifier) == key:
            return s
    return None


def _set_value(sock, value, source, where):
    if not hasattr(sock, "default_value"):
        _fail(source, where, "socket %r has no value to set" % sock.identifier)
    cur = sock.default_value
    try:
        if hasattr(cur, "__len__"):
            vals = list(value) if isinstance(value, (list, tuple)) else [value] * len(cur)
            if len(vals) != len(cur):
                # colours may come as RGB; vectors as 3
                if len(cur) == 4 and len(vals) == 3:
                    vals = vals + [1.0]
                else:
                    _fail(source, where, "socket %r wants %d values, got %r"
                          % (sock.identifier, len(cur), value))
            sock.default_value = vals
        elif isinstance(cur, bool):
            sock.default_value = bool(value)
        elif isinstance(cur, int):
            sock.default_value = int(round(float(value)))
        else:
            if isinstance(value, (list, tuple)):
                _fail(source, where, "socket %r wants a number, got %r"
                      % (sock.identifier, value))
            sock.default_value = float(value)
    except (TypeError, ValueError) as e:
        _fail(source, where, "cannot set socket %r to %r (%s)" % (sock.identifier, value, e))
    _check_stored(sock.default_value, value, source, where, "socket %r" % sock.identifier)


def _f32(x):
    return struct.unpack("f", struct.pack("f", float(x)))[0]


def _check_stored(stored, wanted, source, where, what):
    """Blender silently clamps values to a socket's hard range (colours, of sockets and
    of colour-ramp stops, to >= 0; ramp positions to [0, 1]; ...), so the material it
    holds is not quite what the graph says. Strict builds refuse that; others build
    Blender's clamped material (which the evaluator must reproduce) and record a warning.
    `source` is the BuildContext."""
    got = list(stored) if hasattr(stored, "__len__") else [stored]
    want = list(wanted) if isinstance(wanted, (list, tuple)) else [wanted] * len(got)
    for k, (g, w) in enumerate(zip(got, want)):
        if isinstance(g, bool) or isinstance(g, int):
            w = bool(w) if isinstance(g, bool) else int(round(float(w)))
            ok = g == w
        else:
            ok = _f32(g) == _f32(w)
        if not ok:
            msg = ("%s: Blender %s stores %r where the graph says %r (clamped to the "
                   "socket's range)" % (what, bpy.app.version_string,
                                        tuple(got) if len(got) > 1 else got[0], wanted))
            if getattr(source, "strict", True):
                _fail(source, where, msg)
            source.warnings.append("%s: %s: %s" % (source, where, msg))
            print("import_material: warning: %s: %s: %s" % (source, where, msg),
                  file=sys.stderr)
            return


def _new_interface_socket(tree, spec, in_out, major, source, where):
    stype = SOCKET_TYPES.get(spec.get("type", "FLOAT"))
    if stype is None:
        _fail(source, where, "unknown interface socket type %r" % spec.get("type"))
    name = spec["name"]
    if major >= 4:
        s = tree.interface.new_socket(name, in_out=in_out, socket_type=stype)
    elif in_out == "INPUT":
        s = tree.inputs.new(stype, name)
    else:
        s = tree.outputs.new(stype, name)
    if "default" in spec and hasattr(s, "default_value"):
        d = spec["default"]
        cur = s.default_value
        if hasattr(cur, "__len__"):
            d = list(d) if isinstance(d, (list, tuple)) else [d] * len(cur)
            if len(d) == 3 and len(cur) == 4:
                d = d + [1.0]
        s.default_value = d
        _check_stored(s.default_value, d, source, where, "default of %r" % name)
    if "min" in spec and hasattr(s, "min_value"):
        s.min_value = spec["min"]
    if "max" in spec and hasattr(s, "max_value"):
        s.max_value = spec["max"]
    return s


def _apply_color_ramp(node, ramp, source, where):
    cr = node.color_ramp
    for key in ("interpolation", "color_mode", "hue_interpolation"):
        if key in ramp:
            try:
                setattr(cr, key, ramp[key])
            except (TypeError, ValueError) as e:
                _fail(source, where, "color_ramp.%s = %r: %s" % (key, ramp[key], e))
    elements = ramp.get("elements", [])
    if not elements:
        _fail(source, where, "color_ramp has no elements")
    while len(cr.elements) > 1:
        cr.elements.remove(cr.elements[-1])
    first = cr.elements[0]
    first.position = elements[0]["position"]
    first.color = _rgba(elements[0]["color"])
    made = [first]
    for e in elements[1:]:
        el = cr.elements.new(e["position"])
        el.color = _rgba(e["color"])
        made.append(el)
    # Blender clamps element colours to >= 0 and positions to [0, 1].
    for k, (el, e) in enumerate(zip(made, elements)):
        what = "color_ramp.elements[%d]" % k
        _check_stored(el.position, e["position"], source, where, what + ".position")
        _check_stored(el.color, _rgba(e["color"]), source, where, what + ".color")


def _rgba(c):
    c = list(c)
    return c + [1.0] if len(c) == 3 else c


def _is_group_like(node_dict):
    return node_dict["type"] in ("ShaderNodeGroup", "NodeGroupInput", "NodeGroupOutput")


def _build_tree(tree, tdict, groups, major, source, prefix):
    """Create nodes and links of tdict in tree (nodes already cleared)."""
    nodes = tdict.get("nodes", [])
    links = tdict.get("links", [])
    linked_in = {}
    linked_out = {}
    for l in links:
        linked_in.setdefault(l["to_node"], set()).add(l["to_socket"])
        linked_out.setdefault(l["from_node"], set()).add(l["from_socket"])

    made = {}
    for i, nd in enumerate(nodes):
        where = "%snodes[%d] %r (%s)" % (prefix, i, nd.get("name"), nd.get("type"))
        if "name" not in nd or "type" not in nd:
            _fail(source, "%snodes[%d]" % (prefix, i), "node needs a name and a type")
        if nd["name"] in made:
            _fail(source, where, "duplicate node name")
        idname = nd["type"]
        if major < 4 and idname == "ShaderNodeTexNoise":
            nd = _noise_for_blender3(nd, linked_in.get(nd["name"], ()),
                                     linked_out.get(nd["name"], ()), source, where)
            idname = nd["type"]
        if major < 4 and idname == "ShaderNodeTexVoronoi":
            # 3.x's Voronoi has no octaves: Detail, Roughness, Lacunarity and Normalize do
            # not exist there, and imsynth's 3.x mode ignores them, as 3.4 would.
            extra = ("Detail", "Roughness", "Lacunarity")
            bad = [k for k in linked_in.get(nd["name"], ()) if k in extra]
            if bad:
                _fail(source, where, "Blender 3.x's Voronoi Texture has no %s socket to link"
                      % ", ".join(sorted(bad)))
            nd = dict(nd)
            nd["inputs"] = {k: v for k, v in nd.get("inputs", {}).items() if k not in extra}
            nd["properties"] = {k: v for k, v in nd.get("properties", {}).items()
                                if k != "normalize"}
        if major < 4 and idname == "ShaderNodeBsdfPrincipled":
            bad = [k for k in list(nd.get("inputs", {})) + list(linked_in.get(nd["name"], ()))
                   if k not in PRINCIPLED_COMMON]
            if bad:
                _fail(source, where, "Blender 3.x's Principled BSDF: inputs %s are not "
                      "supported (only %s map between 3.x and 4.x)"
                      % (", ".join(sorted(set(bad))), ", ".join(PRINCIPLED_COMMON)))
        try:
            node = tree.nodes.new(idname)
        except RuntimeError:
            _fail(source, where, "Blender %s has no node type %r"
                  % (bpy.app.version_string, idname))
        node.name = nd["name"]
        if node.name != nd["name"]:
            _fail(source, where, "Blender renamed the node to %r" % node.name)
        if "label" in nd:
            node.label = nd["label"]
        loc = nd.get("location", [0.0, 0.0])
        node.location = (loc[0], loc[1])
        if idname == "ShaderNodeGroup":
            gname = nd.get("group")
            if gname not in groups:
                _fail(source, where, "group %r is not defined in groups" % gname)
            node.node_tree = groups[gname]
        for prop, value in nd.get("properties", {}).items():
            if not hasattr(node, prop):
                _fail(source, where, "Blender %s has no property %r on %s"
                      % (bpy.app.version_string, prop, idname))
            try:
                setattr(node, prop, value)
            except (TypeError, ValueError, AttributeError) as e:
                _fail(source, where, "property %s = %r: %s" % (prop, value, e))
        if idname == "ShaderNodeBsdfPrincipled" and major < 4 \
                and "IOR" not in nd.get("inputs", {}):
            node.inputs["IOR"].default_value = PRINCIPLED_4X_IOR_DEFAULT
        by_name = _is_group_like(nd)
        for key, value in nd.get("inputs", {}).items():
            sock = _find_socket(node.inputs, key, by_name)
            if sock is None:
                _fail(source, where, "Blender %s has no input socket %r"
                      % (bpy.app.version_string, key))
            _set_value(sock, value, source, where)
        for key, value in nd.get("outputs", {}).items():
            sock = _find_socket(node.outputs, key, by_name)
            if sock is None:
                _fail(source, where, "no output socket %r" % key)
            _set_value(sock, value, source, where)
        if "color_ramp" in nd:
            if idname != "ShaderNodeValToRGB":
                _fail(source, where, "color_ramp on a node that is not a Color Ramp")
            _apply_color_ramp(node, nd["color_ramp"], source, where)
        made[nd["name"]] = (node, by_name)

    for i, l in enumerate(links):
        where = "%slinks[%d] %s:%s -> %s:%s" % (prefix, i, l.get("from_node"),
                                                 l.get("from_socket"), l.get("to_node"),
                                                 l.get("to_socket"))
        if l.get("from_node") not in made or l.get("to_node") not in made:
            _fail(source, where, "link names a missing node")
        fnode, fby = made[l["from_node"]]
        tnode, tby = made[l["to_node"]]
        fs = _find_socket(fnode.outputs, l["from_socket"], fby)
        ts = _find_socket(tnode.inputs, l["to_socket"], tby)
        if fs is None:
            _fail(source, where, "node %r has no output socket %r in Blender %s"
                  % (fnode.name, l["from_socket"], bpy.app.version_string))
        if ts is None:
            _fail(source, where, "node %r has no input socket %r in Blender %s"
                  % (tnode.name, l["to_socket"], bpy.app.version_string))
        tree.links.new(fs, ts)
    return made


def _group_order(groups, source):
    """Group names so that each comes after the groups it instances."""
    order, state = [], {}

    def visit(name, path):
        if state.get(name) == "done":
            return
        if state.get(name) == "active":
            _fail(source, "groups", "group %r contains itself (%s)"
                  % (name, " -> ".join(path + [name])))
        if name not in groups:
            _fail(source, "groups", "group %r is used but not defined" % name)
        state[name] = "active"
        for nd in groups[name].get("nodes", []):
            if nd.get("type") == "ShaderNodeGroup":
                visit(nd.get("group"), path + [name])
        state[name] = "done"
        order.append(name)

    for name in groups:
        visit(name, [])
    return order


class BuildContext:
    """What the builders pass around as `source`: the file name for messages (str()),
    whether clamped values are errors, and the warnings collected."""

    def __init__(self, source, strict, warnings):
        self.source = source
        self.strict = strict
        self.warnings = warnings

    def __str__(self):
        return str(self.source)


def build_material(data, major=None, source="<json>", name=None, strict=False,
                   warnings=None):
    """Create and return a new bpy material built from the graph dict `data`.
    strict: refuse values Blender would clamp (else they are clamped, and a message is
    appended to `warnings` if given, and printed)."""
    if major is None:
        major = blender_major()
    source = BuildContext(source, strict, warnings if warnings is not None else [])
    if data.get("format") != FORMAT:
        _fail(source, "format", "expected %r, got %r" % (FORMAT, data.get("format")))
    gdefs = data.get("groups", {}) or {}
    groups = {}
    for gname in _group_order(gdefs, source):
        gd = gdefs[gname]
        tree = bpy.data.node_groups.new(gname, "ShaderNodeTree")
        for k, spec in enumerate(gd.get("inputs", [])):
            _new_interface_socket(tree, spec, "INPUT", major, source,
                                  "groups[%r].inputs[%d]" % (gname, k))
        for k, spec in enumerate(gd.get("outputs", [])):
            _new_interface_socket(tree, spec, "OUTPUT", major, source,
                                  "groups[%r].outputs[%d]" % (gname, k))
        _build_tree(tree, gd, groups, major, source, "groups[%r]." % gname)
        groups[gname] = tree
    mat = bpy.data.materials.new(name or data.get("name", "Material"))
    mat.use_nodes = True
    tree = mat.node_tree
    for n in list(tree.nodes):
        tree.nodes.remove(n)
    _build_tree(tree, data, groups, major, source, "")
    return mat


def load_json(path):
    try:
        with open(path) as f:
            return json.load(f)
    except ValueError as e:
        raise ImportError_("%s: bad JSON: %s" % (path, e))
    except OSError as e:
        raise ImportError_("%s: %s" % (path, e.strerror))


# ---- the scene (DESIGN.md) ------------------------------------------------------------

def _clear_scene_objects(scene):
    for ob in list(scene.objects):
        bpy.data.objects.remove(ob, do_unlink=True)


def build_plane(scene, transform=None):
    """2 m x 2 m plane at the origin, normal +Z, UV map UVMap spanning (0,0)-(1,1).
    `transform` (location, rotation_euler: our scene file's object transform) moves the
    texture space only: the object gets that matrix_world and its mesh the inverse, so the
    plane stays where it is while Object and Generated coordinates move with the object."""
    corners = [(-1.0, -1.0, 0.0), (1.0, -1.0, 0.0), (1.0, 1.0, 0.0), (-1.0, 1.0, 0.0)]
    if transform:
        from mathutils import Euler, Vector
        loc = Vector(transform.get("location", (0.0, 0.0, 0.0)))
        rot = Euler(transform.get("rotation_euler", (0.0, 0.0, 0.0)), "XYZ").to_matrix()
        inv = rot.transposed()
        corners = [tuple(inv @ (Vector(c) - loc)) for c in corners]
    mesh = bpy.data.meshes.new("Plane")
    mesh.from_pydata(corners, [], [(0, 1, 2, 3)])
    uv = mesh.uv_layers.new(name="UVMap")
    for loop, (u, v) in zip(mesh.loops, [(0, 0), (1, 0), (1, 1), (0, 1)]):
        uv.data[loop.index].uv = (u, v)
    mesh.update()
    ob = bpy.data.objects.new("Plane", mesh)
    if transform:
        ob.location = transform.get("location", (0.0, 0.0, 0.0))
        ob.rotation_mode = "XYZ"
        ob.rotation_euler = transform.get("rotation_euler", (0.0, 0.0, 0.0))
    scene.collection.objects.link(ob)
    return ob


def load_scene_file(path):
    """Our scene file (assets/scene.json's format, imsynth-scene/1) as the settings
    build_scene takes: the first light, the world, resolution, filter and the plane's object
    transform. Only what may differ between our scene files is read: the camera and the
    plane's vertices are DESIGN.md's."""
    with open(path) as f:
        j = json.load(f)
    if j.get("format") != "imsynth-scene/1":
        raise ImportError_("%s: not an imsynth-scene/1 file" % path)
    try:
        light = j["lights"][0]
        world = j["world"]
        plane = j["objects"][0]
        return {"res": int(j["resolution"][0]), "filter_width": float(j["film"]["filter_width"]),
                "transform": plane.get("transform"),
                "light_location": tuple(float(v) for v in light["location"]),
                "light_radius": float(light["radius"]), "light_power": float(light["power"]),
                "light_color": tuple(float(v) for v in light["color"]),
                "world_color": float(world["color"][0]) * float(world.get("strength", 1.0))}
    except (KeyError, IndexError, TypeError, ValueError) as e:
        raise ImportError_("%s: %s" % (path, e))


def build_scene(scene=None, material=None, res=256, light=True, world_color=0.0509,
                samples=None, filter_width=1.5, settings=None):
    """Build DESIGN.md's scene in `scene` (default: the current one), replacing its objects;
    `material` (if any) goes on the plane. The reference renderer reuses this with
    light=False, world_color=0, filter_width=0.01 and res=128. `settings` (from
    load_scene_file) overrides the light, world, resolution and filter: another of our
    scene files, e.g. assets/scene-flash.json. Returns the plane object."""
    st = settings or {}
    res = st.get("res", res)
    filter_width = st.get("filter_width", filter_width)
    world_color = st.get("world_color", world_color)
    scene = scene or bpy.context.scene
    _clear_scene_objects(scene)
    plane = build_plane(scene, st.get("transform"))
    if material is not None:
        plane.data.materials.append(material)

    cam_data = bpy.data.cameras.new("Camera")
    cam_data.type = "ORTHO"
    cam_data.ortho_scale = 2.0
    cam = bpy.data.objects.new("Camera", cam_data)
    cam.location = (0.0, 0.0, 2.0)
    cam.rotation_euler = (0.0, 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam

    if light:
        ld = bpy.data.lights.new("Light", "POINT")
        ld.energy = st.get("light_power", 9.25)
        ld.shadow_soft_size = st.get("light_radius", 0.1)
        ld.color = st.get("light_color", (1.0, 1.0, 1.0))
        lo = bpy.data.objects.new("Light", ld)
        lo.location = st.get("light_location", (0.45, 0.35, 0.55))
        scene.collection.objects.link(lo)

    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    bg = world.node_tree.nodes.get("Background")
    bg.inputs["Color"].default_value = (world_color, world_color, world_color, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    scene.world = world

    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x = res
    r.resolution_y = res
    r.resolution_percentage = 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.film_transparent = False
    r.use_border = False
    c = scene.cycles
    c.device = "CPU"
    c.use_adaptive_sampling = False
    c.use_denoising = False
    if hasattr(c, "use_preview_denoising"):
        c.use_preview_denoising = False
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.pixel_filter_type = "BLACKMAN_HARRIS"
    c.filter_width = filter_width
    c.seed = 0
    c.use_animated_seed = False
    if samples is not None:
        c.samples = samples
    vs = scene.view_settings
    vs.view_transform = "Standard"
    vs.look = "None"
    vs.exposure = 0.0
    vs.gamma = 1.0
    vs.use_curve_mapping = False
    scene.display_settings.display_device = "sRGB"
    return plane


def set_exr_output(scene, path):
    """Float32 RGB EXR, ZIP: values as the film holds them (linear, no view transform)."""
    s = scene.render.image_settings
    s.file_format = "OPEN_EXR"
    s.color_mode = "RGB"
    s.color_depth = "32"
    s.exr_codec = "ZIP"
    if hasattr(s, "use_preview"):
        s.use_preview = False
    scene.render.filepath = path
    scene.render.use_file_extension = False


def _main(argv):
    import argparse
    p = argparse.ArgumentParser(prog="import_material.py")
    p.add_argument("material")
    p.add_argument("--save", required=True, help="write this .blend")
    p.add_argument("--scene", action="store_true", help="also build DESIGN.md's scene")
    p.add_argument("--scene-file", help="build the scene of this scene file instead "
                   "(e.g. assets/scene-flash.json); implies --scene")
    p.add_argument("--strict", action="store_true",
                   help="refuse values Blender would clamp (negative colours, ...)")
    a = p.parse_args(argv)
    data = load_json(a.material)
    # Start from an empty file: the startup file's cube, its material and light would
    # otherwise be saved beside ours.
    for coll in (bpy.data.objects, bpy.data.meshes, bpy.data.materials, bpy.data.lights,
                 bpy.data.cameras, bpy.data.node_groups):
        for block in list(coll):
            coll.remove(block)
    mat = build_material(data, blender_major(), source=a.material, strict=a.strict)
    if a.scene or a.scene_file:
        settings = load_scene_file(a.scene_file) if a.scene_file else None
        build_scene(bpy.context.scene, mat, settings=settings)
    else:
        mat.use_fake_user = True
    bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(a.save))
    print("import_material: wrote %s (Blender %s)" % (a.save, bpy.app.version_string))


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    try:
        _main(args)
    except ImportError_ as e:
        print("import_material: error: %s" % e, file=sys.stderr)
        sys.exit(1)
