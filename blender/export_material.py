"""Export a Blender material to our graph JSON (FORMAT.md), the reverse of import_material.

    blender -b in.blend -P blender/export_material.py -- [--material NAME] -o out.json

Runs in Blender 3.4 and 4.x. Without --material, the file must hold exactly one material
with nodes. Only what shadergraph understands is written, as blender/node_vocabulary.json
(generated from the C registry, checked by tests/unit/test_blender_vocabulary.c) lists it:
any other node, a link into a socket we do not know, or a value we would silently drop
is an error naming the node and the material. Frames are dropped (their children keep
their absolute locations); muted nodes and muted links are refused (Cycles passes a
muted node's inputs through, which we do not model).

Blender 3.x differences, translated into the 4.x vocabulary:
- ShaderNodeTexMusgrave becomes a ShaderNodeTexNoise with noise_type = musgrave_type,
  normalize off, Detail - 1 and Roughness = Lacunarity ^ -Dimension as 3.4 computes it
  (blender/compat_noise.py, the inverse of what import_material does).
- A 3.x Noise Texture's Roughness is clamped to [0, 1] by its kernel: written clamped.
- Principled BSDF: Base Color, Metallic, Roughness, Normal, IOR and Alpha are written;
  any other input that is linked or differs from 3.x's default is refused.
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
PRINCIPLED_COMMON = ("Base Color", "Metallic", "Roughness", "Normal", "IOR", "Alpha")
GROUPISH = ("ShaderNodeGroup", "NodeGroupInput", "NodeGroupOutput")
FLT_MAX = 3.4028234663852886e38


class ExportError(Exception):
    pass


def load_vocabulary(path=None):
    path = path or os.path.join(HERE, "node_vocabulary.json")
    try:
        with open(path) as f:
            return json.load(f)["nodes"]
    except (OSError, ValueError, KeyError) as e:
        raise ExportError("%s: cannot read the node vocabulary (%s)" % (path, e))


def _f32(x):
    return struct.unpack("f", struct.pack("f", float(x)))[0]


def _num(x):
    """The shortest decimal that reads back as the same float32 (Blender stores float32)."""
    x = float(x)
    if x != x or x in (float("inf"), float("-inf")):
        raise ValueError("non-finite value %r" % x)
    f = _f32(x)
    for digits in range(6, 10):
        s = float("%.*g" % (digits, f))
        # The shortest form of FLT_MAX (3.4028235e38) exceeds FLT_MAX as a double, and a
        # strict reader takes it for an overflow: keep such values exact.
        if _f32(s) == f and abs(s) <= FLT_MAX:
            return s
    return f


def _value(v):
    if hasattr(v, "__len__"):
        return [_num(c) for c in v]
    if isinstance(v, bool):
        return 1.0 if v else 0.0
    return _num(v)


def _is_virtual(sock):
    return sock.bl_idname == "NodeSocketVirtual" or sock.identifier == "__extend__"


def _absolute_location(node):
    x, y = node.location
    p = node.parent
    while p is not None:
        x += p.location[0]
        y += p.location[1]
        p = p.parent
    return [_num(x), _num(y)]


def _interface_type(idname):
    for prefix, t in (("NodeSocketFloat", "FLOAT"), ("NodeSocketVector", "VECTOR"),
                      ("NodeSocketColor", "RGBA"), ("NodeSocketShader", "SHADER"),
                      ("NodeSocketInt", "INT"), ("NodeSocketBool", "BOOLEAN")):
        if idname.startswith(prefix):
            return t
    return None


class Exporter:
    def __init__(self, material, vocab):
        self.mat = material
        self.vocab = vocab
        self.major = bpy.app.version[0]
        self.groups = {}
        self._fresh = {}

    def fail(self, where, msg):
        raise ExportError("material %r: %s: %s" % (self.mat.name, where, msg))

    def fresh_defaults(self, idname):
        """Input default values of a node of this type as Blender creates it."""
        if idname not in self._fresh:
            tmp = bpy.data.node_groups.new("imsynth-export-tmp", "ShaderNodeTree")
            try:
                n = tmp.nodes.new(idname)
                self._fresh[idname] = {
                    s.identifier: (tuple(s.default_value) if hasattr(s.default_value, "__len__")
                                   else s.default_value)
                    for s in n.inputs if hasattr(s, "default_value")}
            finally:
                bpy.data.node_groups.remove(tmp)
        return self._fresh[idname]

    # ---- one tree -------------------------------------------------------------------

    def tree(self, tree, where):
        nodes, links = [], []
        names = set()
        translated = {}
        for node in tree.nodes:
            if node.bl_idname == "NodeFrame":
                continue
            nwhere = "%snode %r (%s)" % (where, node.name, node.bl_idname)
            if node.mute:
                self.fail(nwhere, "muted nodes are not supported")
            d = self.node(node, nwhere)
            translated[node.name] = d
            names.add(node.name)
            nodes.append(d)
        for link in tree.links:
            fn, tn = link.from_node, link.to_node
            lwhere = "%slink %s:%s -> %s:%s" % (where, fn.name, link.from_socket.identifier,
                                                tn.name, link.to_socket.identifier)
            if _is_virtual(link.from_socket) or _is_virtual(link.to_socket):
                continue
            if link.is_muted:
                self.fail(lwhere, "muted links are not supported")
            if not link.is_valid:
                self.fail(lwhere, "Blender marks this link invalid")
            if fn.name not in names or tn.name not in names:
                self.fail(lwhere, "link to a node that is not exported")
            fs = self.socket_key(fn, link.from_socket, translated[fn.name], "outputs", lwhere)
            ts = self.socket_key(tn, link.to_socket, translated[tn.name], "inputs", lwhere)
            links.append({"from_node": fn.name, "from_socket": fs,
                          "to_node": tn.name, "to_socket": ts})
        return nodes, links

    def socket_key(self, node, sock, d, direction, where):
        if node.bl_idname in GROUPISH:
            return sock.name
        ident = sock.identifier
        known = [s["identifier"] for s in self.vocab[d["type"]][direction]]
        if ident not in known:
            self.fail(where, "socket %r of %s is not supported" % (ident, d["type"]))
        if node.bl_idname == "ShaderNodeBsdfPrincipled" and self.major < 4 \
                and direction == "inputs" and ident not in PRINCIPLED_COMMON:
            self.fail(where, "Blender 3.x Principled BSDF input %r has no 4.x equivalent "
                      "we support" % ident)
        return ident

    # ---- one node -------------------------------------------------------------------

    def node(self, node, where):
        idname = node.bl_idname
        if idname == "ShaderNodeTexMusgrave" and self.major < 4:
            return self.musgrave(node, where)
        if idname not in self.vocab:
            self.fail(where, "node type %s is not supported" % idname)
        voc = self.vocab[idname]
        d = {"name": node.name, "type": idname, "location": _absolute_location(node)}
        if node.label:
            d["label"] = node.label
        props = {}
        for pname, pdef in voc["properties"].items():
            if pdef["kind"] == "color_ramp":
                d["color_ramp"] = self.color_ramp(node)
                continue
            if not hasattr(node, pname):
                continue  # a 4.x property this Blender lacks: the 4.x default is right
            v = getattr(node, pname)
            if pdef["kind"] == "enum":
                if v not in pdef["values"]:
                    self.fail(where, "%s = %r is not supported (have %s)"
                              % (pname, v, ", ".join(pdef["values"])))
                props[pname] = v
            elif pdef["kind"] == "bool":
                props[pname] = bool(v)
        if props:
            d["properties"] = props
        if idname == "ShaderNodeGroup":
            if node.node_tree is None:
                self.fail(where, "group node without a node tree")
            d["group"] = self.group(node.node_tree)
        d_inputs = {} if idname in ("NodeGroupInput", "NodeGroupOutput") else \
            self.input_values(node, voc, where)
        if d_inputs:
            d["inputs"] = d_inputs
        if idname == "ShaderNodeValue":
            d["outputs"] = {"Value": _value(node.outputs[0].default_value)}
        elif idname == "ShaderNodeRGB":
            d["outputs"] = {"Color": _value(node.outputs[0].default_value)}
        if idname == "ShaderNodeTexNoise" and self.major < 4 and "inputs" in d:
            r = d["inputs"].get("Roughness")
            if r is not None:
                d["inputs"]["Roughness"] = min(max(r, 0.0), 1.0)
        return d

    def input_values(self, node, voc, where):
        out = {}
        groupish = node.bl_idname in GROUPISH
        known = {s["identifier"]: s for s in voc["inputs"]}
        fresh = None
        for sock in node.inputs:
            if _is_virtual(sock) or sock.type == "SHADER" or not hasattr(sock, "default_value"):
                continue
            key = sock.name if groupish else sock.identifier
            spec = known.get(sock.identifier)
            principled3 = (node.bl_idname == "ShaderNodeBsdfPrincipled" and self.major < 4
                           and sock.identifier not in PRINCIPLED_COMMON)
            if not groupish and (spec is None or principled3):
                # A socket we do not model: harmless only while unlinked and untouched.
                if sock.is_linked:
                    self.fail(where, "input %r is not supported" % sock.identifier)
                if fresh is None:
                    fresh = self.fresh_defaults(node.bl_idname)
                v = sock.default_value
                v = tuple(v) if hasattr(v, "__len__") else v
                if sock.identifier in fresh and fresh[sock.identifier] != v:
                    self.fail(where, "input %r is set to %r, which is not supported (only "
                              "its default %r is)" % (sock.identifier, v,
                                                      fresh[sock.identifier]))
                continue
            if sock.is_linked or not sock.enabled:
                continue
            if spec is not None and spec["implicit"]:
                continue  # unlinked: the node reads its implicit coordinate/normal
            try:
                out[key] = _value(sock.default_value)
            except ValueError as e:
                self.fail(where, "input %r: %s" % (key, e))
        return out

    def color_ramp(self, node):
        cr = node.color_ramp
        return {"interpolation": cr.interpolation, "color_mode": cr.color_mode,
                "hue_interpolation": cr.hue_interpolation,
                "elements": [{"position": _num(e.position), "color": _value(e.color)}
                             for e in cr.elements]}

    def musgrave(self, node, where):
        """3.x Musgrave -> 4.x Noise Texture (the inverse of compat_noise's translation)."""
        try:
            from compat_noise import musgrave_roughness_for_export
        except ImportError as e:
            self.fail(where, "blender/compat_noise.py is needed to translate a Musgrave "
                      "Texture (%s)" % e)
        for ident in ("Detail", "Dimension", "Lacunarity"):
            if node.inputs[ident].is_linked:
                self.fail(where, "Musgrave with %s linked cannot be written as one Noise "
                          "Texture" % ident)
        detail = node.inputs["Detail"].default_value
        if detail < 1.0:
            self.fail(where, "Musgrave Detail %g < 1 has no Noise Texture equivalent" % detail)
        dims = node.musgrave_dimensions
        lac = _num(node.inputs["Lacunarity"].default_value)
        rough = musgrave_roughness_for_export(node.inputs["Dimension"].default_value, lac)
        d = {"name": node.name, "type": "ShaderNodeTexNoise",
             "location": _absolute_location(node),
             "properties": {"noise_dimensions": dims, "noise_type": node.musgrave_type},
             "inputs": {}}
        if node.musgrave_type == "FBM":
            d["properties"]["normalize"] = False  # 4.x normalizes only fBM, by default
        if node.label:
            d["label"] = node.label
        for ident in ("Scale", "Offset", "Gain"):
            s = node.inputs[ident]
            if not s.is_linked and s.enabled:
                d["inputs"][ident] = _value(s.default_value)
        if dims in ("1D", "4D") and not node.inputs["W"].is_linked:
            d["inputs"]["W"] = _value(node.inputs["W"].default_value)
        d["inputs"].update({"Detail": _num(detail - 1.0), "Roughness": _num(rough),
                            "Lacunarity": _num(lac), "Distortion": 0.0})
        return d

    # ---- groups ---------------------------------------------------------------------

    def interface(self, tree):
        ins, outs = [], []
        if self.major >= 4:
            items = [(it.in_out, it) for it in tree.interface.items_tree
                     if it.item_type == "SOCKET"]
        else:
            items = [("INPUT", s) for s in tree.inputs] + [("OUTPUT", s) for s in tree.outputs]
        for in_out, s in items:
            idname = s.socket_type if self.major >= 4 else s.bl_socket_idname
            t = _interface_type(idname)
            if t is None:
                self.fail("group %r" % tree.name, "interface socket %r of type %s is not "
                          "supported" % (s.name, idname))
            spec = {"name": s.name, "type": t}
            if in_out == "INPUT":
                if hasattr(s, "default_value"):
                    spec["default"] = _value(s.default_value)
                # Blender's unbounded range is +-FLT_MAX: leave it unsaid.
                if hasattr(s, "min_value") and _f32(s.min_value) > -FLT_MAX:
                    spec["min"] = _num(s.min_value)
                if hasattr(s, "max_value") and _f32(s.max_value) < FLT_MAX:
                    spec["max"] = _num(s.max_value)
            lst = ins if in_out == "INPUT" else outs
            if any(o["name"] == s.name for o in lst):
                self.fail("group %r" % tree.name, "two %s sockets named %r"
                          % (in_out.lower(), s.name))
            lst.append(spec)
        return ins, outs

    def group(self, tree):
        name = tree.name
        if name in self.groups:
            if self.groups[name] is None:
                self.fail("group %r" % name, "contains itself")
            return name
        self.groups[name] = None  # in progress: catches recursion
        ins, outs = self.interface(tree)
        nodes, links = self.tree(tree, "group %r: " % name)
        self.groups[name] = {"inputs": ins, "outputs": outs, "nodes": nodes, "links": links}
        return name

    def export(self):
        if not self.mat.use_nodes or self.mat.node_tree is None:
            self.fail("material", "does not use nodes")
        nodes, links = self.tree(self.mat.node_tree, "")
        if not any(n["type"] == "ShaderNodeOutputMaterial" for n in nodes):
            self.fail("material", "has no Material Output")
        return {"format": FORMAT, "name": self.mat.name, "nodes": nodes, "links": links,
                "groups": self.groups}


def export_material(material, vocab=None):
    return Exporter(material, vocab or load_vocabulary()).export()


def pick_material(name):
    if name is not None:
        m = bpy.data.materials.get(name)
        if m is None:
            raise ExportError("%s: no material named %r (have %s)" % (
                bpy.data.filepath, name, ", ".join(sorted(x.name for x in bpy.data.materials))))
        return m
    with_nodes = [m for m in bpy.data.materials if m.use_nodes]
    if len(with_nodes) > 1:
        # Prefer the materials objects actually use.
        used = {slot.material for ob in bpy.data.objects for slot in ob.material_slots
                if slot.material is not None and slot.material.use_nodes}
        if len(used) == 1:
            return used.pop()
    if len(with_nodes) != 1:
        raise ExportError("%s: %d materials with nodes (%s): choose one with --material"
                          % (bpy.data.filepath, len(with_nodes),
                             ", ".join(sorted(m.name for m in with_nodes))))
    return with_nodes[0]


def main(argv):
    import argparse
    ap = argparse.ArgumentParser(prog="export_material.py")
    ap.add_argument("--material")
    ap.add_argument("-o", "--output", required=True)
    a = ap.parse_args(argv)
    mat = pick_material(a.material)
    data = export_material(mat)
    text = json.dumps(data, indent=1) + "\n"
    tmp = a.output + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, a.output)
    print("export_material: wrote %s (material %r, Blender %s)"
          % (a.output, mat.name, bpy.app.version_string))


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    try:
        main(args)
    except ExportError as e:
        print("export_material: error: %s" % e, file=sys.stderr)
        sys.exit(1)
