"""Inside Blender: import every case graph that lists this Blender's version, export it
again with export_material, and write <out_dir>/<case>.json (or <case>.error).

    blender -b --factory-startup -P tests/blender/export_cases.py -- BLENDER_DIR CASES OUT
"""
import glob
import json
import os
import sys

import bpy

blender_dir, cases_root, out_dir = sys.argv[sys.argv.index("--") + 1:][:3]
sys.path.insert(0, blender_dir)
import export_material  # noqa: E402
import import_material  # noqa: E402

version = "%d.%d" % bpy.app.version[:2]
vocab = export_material.load_vocabulary()
for graph_path in sorted(glob.glob(os.path.join(cases_root, "*", "graph.json"))):
    case_dir = os.path.dirname(graph_path)
    case = os.path.basename(case_dir)
    with open(os.path.join(case_dir, "case.json")) as f:
        if version not in json.load(f)["versions"]:
            continue
    for m in list(bpy.data.materials):
        bpy.data.materials.remove(m)
    for g in list(bpy.data.node_groups):
        bpy.data.node_groups.remove(g)
    try:
        mat = import_material.build_material(import_material.load_json(graph_path),
                                             source=graph_path, warnings=[])
        data = export_material.export_material(mat, vocab)
        with open(os.path.join(out_dir, case + ".json"), "w") as f:
            json.dump(data, f, indent=1)
    except Exception as e:  # reported by the driver, per case
        with open(os.path.join(out_dir, case + ".error"), "w") as f:
            f.write("%s: %s\n" % (type(e).__name__, e))
with open(os.path.join(out_dir, "VERSION"), "w") as f:
    f.write(bpy.app.version_string + "\n")
