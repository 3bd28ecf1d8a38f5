"""casekit: build node-reference cases (tests/reference/nodes/<case>/).

A case is a material graph (graph.json, FORMAT.md's imsynth-graph/1) and case.json naming
one socket to compare ("NODE:SOCKET"), the Blender versions to compare against, and the
tolerance. blender/render_node_references.py renders that socket through an Emission
shader at 1 sample with a 0.01 px filter, 128 x 128, so each EXR pixel is the socket's
value at the pixel centre; tests/unit/test_blender_nodes.c evaluates our graph at the
same points and compares.

Plain python3, no bpy. Typical use:

    from casekit import Graph, write_case
    g = Graph()
    co = g.pixel_coords(space="generated")
    n = g.node("ShaderNodeTexNoise", inputs={"Scale": 5.0}, properties={"noise_type": "FBM"})
    g.link(co, (n, "Vector"))
    write_case("noise_fbm", g, socket=(n, "Fac"), versions=("3.4", "4.3"))

Why coordinates are snapped inside the graph: Cycles' one camera ray per pixel may land up
to 0.005 px (half the 0.01 px filter width) away from the pixel centre, so a texture
evaluated at the raw hit point could differ from ours (which uses exact centres) wherever
the texture is steep or discontinuous. Measured (tc_* cases): at 1 sample the raw
Generated/Object/UV coordinates agree with the exact centres to 1e-7 (< 1e-5 px) in 3.4
and 4.3, but only snapping makes the two sides bit-identical, which cell borders and
floor() need. pixel_coords() rebuilds the pixel index from the hit
point with floor() and returns the exact centre, computed in float by operations whose
results are exact (power-of-two scales), so Blender and our evaluator see the same bits.

Stale references: write_case() refuses to change a case's graph or socket while rendered
references (blender-*.exr) exist beside it, because they would then describe another
graph. Pass force=True (or set CASEKIT_FORCE=1) to rewrite it; the stale EXRs are deleted
so the driver renders them again.
"""

import json
import os
import re

FORMAT = "imsynth-graph/1"
CASES_DIR = os.path.dirname(os.path.abspath(__file__))
VERSIONS = ("3.4", "4.3")

# Blender's default node names (its UI names) for the types cases use most; others get
# their idname without the prefix, split at capitals.
_DEFAULT_NAMES = {
    "ShaderNodeOutputMaterial": "Material Output",
    "ShaderNodeTexCoord": "Texture Coordinate",
    "ShaderNodeVectorMath": "Vector Math",
    "ShaderNodeMath": "Math",
    "ShaderNodeSeparateXYZ": "Separate XYZ",
    "ShaderNodeCombineXYZ": "Combine XYZ",
    "ShaderNodeSeparateColor": "Separate Color",
    "ShaderNodeCombineColor": "Combine Color",
    "ShaderNodeMapRange": "Map Range",
    "ShaderNodeTexNoise": "Noise Texture",
    "ShaderNodeTexWhiteNoise": "White Noise Texture",
    "ShaderNodeTexVoronoi": "Voronoi Texture",
    "ShaderNodeValToRGB": "Color Ramp",
    "ShaderNodeMix": "Mix",
    "ShaderNodeMixRGB": "Mix",
    "ShaderNodeBsdfPrincipled": "Principled BSDF",
    "ShaderNodeEmission": "Emission",
    "ShaderNodeBump": "Bump",
    "ShaderNodeGroup": "Group",
    "NodeGroupInput": "Group Input",
    "NodeGroupOutput": "Group Output",
    "NodeReroute": "Reroute",
    "ShaderNodeValue": "Value",
    "ShaderNodeRGB": "RGB",
    "ShaderNodeInvert": "Invert Color",
    "ShaderNodeMapping": "Mapping",
    "ShaderNodeClamp": "Clamp",
}


def _default_name(idname):
    if idname in _DEFAULT_NAMES:
        return _DEFAULT_NAMES[idname]
    base = re.sub(r"^(ShaderNode|Node)", "", idname)
    return re.sub(r"(?<=[a-z0-9])(?=[A-Z])", " ", base) or idname


def _plain(value):
    """JSON-ready copy of a socket value (tuples become lists, numbers stay numbers)."""
    if isinstance(value, (list, tuple)):
        return [float(v) for v in value]
    if isinstance(value, bool):
        return value
    if isinstance(value, (int, float)):
        return float(value)
    raise TypeError("casekit: socket value must be a number or a list of numbers, got %r"
                    % (value,))


def _check_ref(ref, what):
    if not (isinstance(ref, tuple) and len(ref) == 2 and all(isinstance(s, str) for s in ref)):
        raise TypeError("casekit: %s must be a (node name, socket identifier) tuple, got %r"
                        % (what, ref))


class Tree:
    """Nodes and links of one node tree (the material, or a group)."""

    def __init__(self):
        self.nodes = []          # node dicts, FORMAT.md shape, in creation order
        self.links = []
        self._by_name = {}

    def node(self, idname, inputs=None, properties=None, outputs=None, name=None,
             label=None, location=None, group=None):
        """Add a node; returns its (unique) name. inputs are keyed by socket identifier."""
        if name is None:
            base = _default_name(idname)
            name, k = base, 0
            while name in self._by_name:
                k += 1
                name = "%s.%03d" % (base, k)
        elif name in self._by_name:
            raise ValueError("casekit: duplicate node name %r" % name)
        n = {"name": name, "type": idname}
        if location is not None:
            n["location"] = [float(location[0]), float(location[1])]
        if label is not None:
            n["label"] = label
        if properties:
            n["properties"] = dict(properties)
        if inputs:
            n["inputs"] = {k: _plain(v) for k, v in inputs.items()}
        if outputs:
            n["outputs"] = {k: _plain(v) for k, v in outputs.items()}
        if group is not None:
            n["group"] = group
        self.nodes.append(n)
        self._by_name[name] = n
        return name

    def _get(self, name):
        if name not in self._by_name:
            raise KeyError("casekit: no node named %r" % name)
        return self._by_name[name]

    def link(self, from_ref, to_ref):
        """Link output socket from_ref = (node, identifier) to input socket to_ref."""
        _check_ref(from_ref, "link source")
        _check_ref(to_ref, "link target")
        self._get(from_ref[0])
        self._get(to_ref[0])
        for l in self.links:
            if (l["to_node"], l["to_socket"]) == to_ref:
                raise ValueError("casekit: input %s:%s is already linked" % to_ref)
        self.links.append({"from_node": from_ref[0], "from_socket": from_ref[1],
                           "to_node": to_ref[0], "to_socket": to_ref[1]})
        return to_ref

    def set_input(self, node, socket, value):
        self._get(node).setdefault("inputs", {})[socket] = _plain(value)

    def set_property(self, node, prop, value):
        self._get(node).setdefault("properties", {})[prop] = value

    def set_output(self, node, socket, value):
        self._get(node).setdefault("outputs", {})[socket] = _plain(value)

    def set_color_ramp(self, node, ramp):
        """ramp: {"interpolation", "color_mode", "hue_interpolation", "elements":
        [{"position", "color": [r, g, b, a]}, ...]} (FORMAT.md)."""
        n = self._get(node)
        if n["type"] != "ShaderNodeValToRGB":
            raise ValueError("casekit: %r is not a Color Ramp" % node)
        r = dict(ramp)
        r["elements"] = [{"position": float(e["position"]), "color": _plain(e["color"])}
                         for e in ramp["elements"]]
        n["color_ramp"] = r

    def _layout(self):
        """Give nodes without a location one: columns by distance to the tree's sinks
        (longest path along links), stacked top to bottom in creation order."""
        succ = {n["name"]: [] for n in self.nodes}
        for l in self.links:
            succ[l["from_node"]].append(l["to_node"])
        depth = {}

        def d(name, stack=()):
            if name in depth:
                return depth[name]
            if name in stack:  # a cycle: the loader will reject it; do not loop here
                return 0
            v = max((d(s, stack + (name,)) + 1 for s in succ[name]), default=0)
            depth[name] = v
            return v

        rows = {}
        for n in self.nodes:
            if "location" in n:
                continue
            col = d(n["name"])
            row = rows.get(col, 0)
            rows[col] = row + 1
            n["location"] = [300.0 - 250.0 * col, 300.0 - 200.0 * row]

    def _json(self):
        self._layout()
        return {"nodes": self.nodes, "links": self.links}


class Group(Tree):
    """A node group: interface inputs/outputs plus a tree with Group Input/Output nodes."""

    def __init__(self, name):
        super().__init__()
        self.name = name
        self.inputs = []
        self.outputs = []
        self.group_input = self.node("NodeGroupInput", name="Group Input")
        self.group_output = self.node("NodeGroupOutput", name="Group Output")

    def add_input(self, name, type_="FLOAT", default=None, min_value=None, max_value=None):
        s = {"name": name, "type": type_}
        if default is not None:
            s["default"] = _plain(default)
        if min_value is not None:
            s["min"] = float(min_value)
        if max_value is not None:
            s["max"] = float(max_value)
        self.inputs.append(s)
        return (self.group_input, name)

    def add_output(self, name, type_="FLOAT"):
        self.outputs.append({"name": name, "type": type_})
        return (self.group_output, name)

    def _json(self):
        d = {"inputs": self.inputs, "outputs": self.outputs}
        d.update(super()._json())
        return d


class Graph(Tree):
    """A material: a tree with a Material Output, plus its groups."""

    def __init__(self, name="Material", res=128):
        super().__init__()
        self.name = name
        self.res = res
        self.groups = {}
        self.output = self.node("ShaderNodeOutputMaterial", name="Material Output")
        self._coords = {}
        self._xy = {}
        self._texcoord = None

    def group(self, name):
        """A new node group, stored in this graph; instance it with group_node()."""
        if name in self.groups:
            raise ValueError("casekit: duplicate group %r" % name)
        grp = Group(name)
        self.groups[name] = grp
        return grp

    def group_node(self, group, inputs=None, tree=None, name=None):
        """Add a ShaderNodeGroup instancing `group` to `tree` (default: the material)."""
        tree = tree or self
        return tree.node("ShaderNodeGroup", inputs=inputs, group=group.name, name=name)

    def texture_coordinate(self):
        if self._texcoord is None:
            self._texcoord = self.node("ShaderNodeTexCoord")
        return self._texcoord

    def pixel_coords(self, space="generated", res=None):
        """The Texture Coordinate of the given space ("generated", "object", "uv") at the
        centre of the pixel the hit point lies in, as an exact float vector; returns
        (node name, "Vector"). The plane's z is a constant (Generated 0.5, Object 0,
        UV 0), so z is set to it rather than snapped (snapping 0 would risk floor(-eps)).

        Generated/UV u in [0,1]:  floor(u * res) + 0.5) / res
        Object x in [-1,1]:       (floor((x + 1) * res/2) + 0.5) / (res/2) - 1
        Every step is exact in float for res a power of two."""
        res = res or self.res
        key = (space, res)
        if key in self._coords:
            return self._coords[key]
        tc = self.texture_coordinate()
        socket = {"generated": "Generated", "object": "Object", "uv": "UV"}.get(space)
        if socket is None:
            raise ValueError("casekit: unknown coordinate space %r" % space)
        src = (tc, socket)
        if space == "object":
            half = res / 2.0
            src = self._vmath("ADD", src, [1.0, 1.0, 0.0], "pixel: +1")
            scale, z, back = half, 0.0, True
        else:
            scale, z, back = float(res), (0.5 if space == "generated" else 0.0), False
        src = self._vmath("MULTIPLY", src, [scale, scale, 0.0], "pixel: x res")
        src = self._vmath("FLOOR", src, None, "pixel: index")
        src = self._vmath("ADD", src, [0.5, 0.5, z], "pixel: centre")
        src = self._vmath("DIVIDE", src, [scale, scale, 1.0], "pixel: / res")
        if back:
            src = self._vmath("SUBTRACT", src, [1.0, 1.0, 0.0], "pixel: -1")
        self._coords[key] = src
        return src

    def _vmath(self, op, a, b, label):
        n = self.node("ShaderNodeVectorMath", properties={"operation": op}, label=label,
                      inputs=None if b is None else {"Vector_001": b})
        self.link(a, (n, "Vector"))
        return (n, "Vector")

    def pixel_xy(self, res=None):
        """Two float sockets: the snapped pixel-centre Generated u and v, both in (0, 1);
        u grows to the right, v upwards (row 0 of the image is the top, v = 1 - 0.5/res)."""
        res = res or self.res
        if res not in self._xy:
            sep = self.node("ShaderNodeSeparateXYZ", label="pixel u, v")
            self.link(self.pixel_coords("generated", res), (sep, "Vector"))
            self._xy[res] = ((sep, "X"), (sep, "Y"))
        return self._xy[res]

    def map_range(self, socket, lo, hi):
        """A float socket lo + s * (hi - lo) for a float socket s in [0, 1] (Map Range,
        linear, unclamped: Cycles computes to_min + (s - 0) / 1 * (to_max - to_min))."""
        n = self.node("ShaderNodeMapRange",
                      properties={"data_type": "FLOAT", "interpolation_type": "LINEAR",
                                  "clamp": False},
                      inputs={"From Min": 0.0, "From Max": 1.0, "To Min": lo, "To Max": hi})
        self.link(socket, (n, "Value"))
        return (n, "Result")

    def to_json(self):
        d = {"format": FORMAT, "name": self.name}
        d.update(Tree._json(self))
        d["groups"] = {name: grp._json() for name, grp in self.groups.items()}
        return d


def _dump(obj):
    return json.dumps(obj, indent=1, sort_keys=False) + "\n"


def _write_atomic(path, text):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def write_case(case, g, socket, versions=VERSIONS, tolerance=1e-4, max_bad_fraction=0.0,
               note="", force=None, cases_dir=None):
    """Write tests/reference/nodes/<case>/graph.json and case.json.

    socket: (node name, socket identifier) of the main tree: an output socket, or an input
    socket (its link source, or its default value). Output sockets win when a node has an
    input and an output with the same identifier (Math's "Value"), as in sg_compile.
    Returns the case directory."""
    if not re.fullmatch(r"[A-Za-z0-9_.-]+", case):
        raise ValueError("casekit: bad case name %r" % case)
    _check_ref(socket, "socket")
    g._get(socket[0])
    versions = list(versions)
    for v in versions:
        if v not in VERSIONS:
            raise ValueError("casekit: case %s: unknown Blender version %r" % (case, v))
    if force is None:
        force = os.environ.get("CASEKIT_FORCE", "") not in ("", "0")
    d = os.path.join(cases_dir or CASES_DIR, case)
    os.makedirs(d, exist_ok=True)
    graph_text = _dump(g.to_json())
    case_obj = {"socket": "%s:%s" % socket, "versions": versions,
                "tolerance": float(tolerance), "max_bad_fraction": float(max_bad_fraction),
                "note": note}
    graph_path = os.path.join(d, "graph.json")
    case_path = os.path.join(d, "case.json")

    old_graph = open(graph_path).read() if os.path.exists(graph_path) else None
    old_socket = None
    if os.path.exists(case_path):
        try:
            old_socket = json.load(open(case_path)).get("socket")
        except ValueError:
            old_socket = None
    changed = (old_graph is not None and old_graph != graph_text) or \
              (old_socket is not None and old_socket != case_obj["socket"])
    refs = sorted(f for f in os.listdir(d) if re.fullmatch(r"blender-.*\.(exr|txt)", f))
    if changed and any(f.endswith(".exr") for f in refs):
        if not force:
            raise RuntimeError(
                "casekit: case %s: graph or socket changed but references %s exist; rerun "
                "with CASEKIT_FORCE=1 to rewrite it (the stale references are deleted)"
                % (case, ", ".join(refs)))
        for f in refs:
            os.remove(os.path.join(d, f))
    # References of versions no longer listed are dropped too.
    for f in refs:
        m = re.fullmatch(r"blender-(.*)\.(exr|txt)", f)
        p = os.path.join(d, f)
        if m and m.group(1) not in versions and os.path.exists(p):
            os.remove(p)
    if old_graph != graph_text:
        _write_atomic(graph_path, graph_text)
    _write_atomic(case_path, _dump(case_obj))
    return d
