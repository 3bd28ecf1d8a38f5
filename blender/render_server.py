"""Runs inside Blender: one process that renders many parameter sets of one super-shader,
the way a Blender-in-the-loop search (VLMaterial's) keeps Blender running between
candidates.

    blender -b --factory-startup -noaudio -P blender/render_server.py -- \
        FULL.json --reply-fd FD [--threads N]

FULL.json is a whole super-shader with its parameter group (`imsynth export GRAPH --full`),
or an extracted sub-shader (`imsynth export GRAPH --seed N`), which has no parameters to set:
each request renders it as it is.
The material is built once (import_material.build_material) on the plane of DESIGN.md's
scene (import_material.build_scene); then each line on stdin is a request, a JSON object

    {"params": {"Noise A Scale": 0.5, ...}, "samples": 4, "seed": 0, "out": "/tmp/c0.exr"}

(params: any subset of the group's parameters) or {"quit": true}. A request sets the
parameters' Value nodes inside the SG_PARAMS_GROUP group (shadergraph.h, "parameters":
the same nodes imsynth binds), renders Cycles at `samples` and writes a float EXR. The reply,
one JSON line on file descriptor FD (not stdout, which Blender fills with its own progress),
gives the seconds spent setting the nodes and inside the render call (which includes Cycles'
shader sync and compile: any change of the node tree makes Cycles re-sync the material).
Before any request, a first line says the Blender version, the seconds from process start
to this script and the seconds building the material and scene.
"""
import json
import os
import sys
import time

T_START = time.time()

import bpy  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import import_material  # noqa: E402

PARAMS_GROUP = "RandomValues"  # SG_PARAMS_GROUP in shadergraph/shadergraph.h


def main(argv):
    import argparse
    p = argparse.ArgumentParser(prog="render_server.py")
    p.add_argument("graph")
    p.add_argument("--reply-fd", type=int, required=True)
    p.add_argument("--threads", type=int, default=0, help="0: all cores")
    a = p.parse_args(argv)
    reply = os.fdopen(a.reply_fd, "w", buffering=1)

    t0 = time.time()
    data = import_material.load_json(a.graph)
    mat = import_material.build_material(data, import_material.blender_major(), source=a.graph)
    scene = bpy.context.scene
    import_material.build_scene(scene, material=mat, res=256, light=True, samples=4,
                                filter_width=1.5)
    # Keep the scene's render data (BVH, images) between renders: in Blender's favour, as a
    # long-running search would set it; only the material changes between candidates.
    scene.render.use_persistent_data = True
    if a.threads:
        scene.render.threads_mode = "FIXED"
        scene.render.threads = a.threads
    # An extracted sub-shader has no parameter group (its parameters are folded into it):
    # it renders as it is, and a request may then name no parameters.
    group = bpy.data.node_groups.get(PARAMS_GROUP)
    values = {n.name: n for n in group.nodes if n.bl_idname == "ShaderNodeValue"} if group else {}
    build_s = time.time() - t0
    reply.write(json.dumps({"blender": bpy.app.version_string, "startup_s": t0 - T_START,
                            "build_s": build_s, "nodes": len(mat.node_tree.nodes),
                            "parameters": len(values)}) + "\n")

    for line in sys.stdin:
        req = json.loads(line)
        if req.get("quit"):
            break
        t0 = time.time()
        for name, v in req.get("params", {}).items():
            if name not in values:
                sys.exit("render_server.py: %s has no parameter %r" % (a.graph, name))
            values[name].outputs[0].default_value = float(v)
        scene.cycles.samples = int(req["samples"])
        scene.cycles.seed = int(req.get("seed", 0))
        import_material.set_exr_output(scene, req["out"])
        t1 = time.time()
        bpy.ops.render.render(write_still=True)
        t2 = time.time()
        reply.write(json.dumps({"set_s": t1 - t0, "render_s": t2 - t1}) + "\n")
    reply.close()


if __name__ == "__main__":
    main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
