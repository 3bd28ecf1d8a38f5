"""The imsynth add-on, headless, as a user would have it: installed from its zip, enabled,
configured, run on an image. Run by tests/cli/addon.sh:

    BLENDER_USER_SCRIPTS=DIR blender -b --factory-startup --python-exit-code 1 \\
        -P tests/blender/test_addon.py -- --zip imsynth_addon.zip --image IMAGE --work DIR
        (--imsynth BIN --model DIR --extra "ARGS" | --outdir PREDICTED)

With --imsynth, the add-on's operator runs imsynth predict itself (and first meets two
errors it must report: no active mesh object, an unreadable image). With --outdir (the
4.3 chroot, where the host's imsynth cannot run), import_result, the operator's last
step, imports an OUTDIR that imsynth predicted outside. Either way the material must be on
the plane with as many nodes as import_material builds from OUTDIR/material.json, the
comparison image must be loaded, and a tiny Cycles render of the scene must run.
Exits 1 with "test_addon: FAIL: ..." on the first failure.
"""

import argparse
import os
import sys

import bpy

MODULE = "imsynth_addon"


class Fail(Exception):
    pass


def expect(cond, msg):
    if not cond:
        raise Fail(msg)
    print("test_addon: ok: %s" % msg)


def install(zip_path):
    scripts = os.environ.get("BLENDER_USER_SCRIPTS")
    expect(scripts, "BLENDER_USER_SCRIPTS is set (the add-on goes to a scratch folder)")
    bpy.ops.preferences.addon_install(filepath=zip_path, overwrite=True)
    init = os.path.join(scripts, "addons", MODULE, "__init__.py")
    expect(os.path.isfile(init), "the zip installs %s" % init)
    bpy.ops.preferences.addon_enable(module=MODULE)
    expect(MODULE in bpy.context.preferences.addons, "the add-on is enabled")
    addon = sys.modules[MODULE]
    expect(os.path.dirname(os.path.abspath(addon.__file__)) == os.path.dirname(init)
           and os.path.dirname(os.path.abspath(addon.import_material.__file__))
           == os.path.dirname(init),
           "the add-on and its import_material load from the installed package")
    expect(hasattr(bpy.ops.imsynth, "material_from_image"), "the operator is registered")
    return addon


def fresh_plane():
    for ob in list(bpy.data.objects):
        if ob.type == "MESH":
            bpy.data.objects.remove(ob, do_unlink=True)
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.view_layer.objects.active
    expect(plane is not None and plane.type == "MESH" and not plane.material_slots,
           "a plane without materials is the active object")
    return plane


def expect_operator_error(fragment, what, **kw):
    try:
        bpy.ops.imsynth.material_from_image(**kw)
    except RuntimeError as e:
        expect(fragment in str(e), "%s: the error says %r" % (what, fragment))
        return
    raise Fail("%s: the operator did not fail" % what)


def run_operator(a, plane):
    # Errors first: each must be a clear report, and leave nothing on the plane.
    bpy.context.view_layer.objects.active = None
    expect_operator_error("needs an active mesh object", "no active object",
                          filepath=a.image)
    bpy.context.view_layer.objects.active = plane
    bad = os.path.join(a.work, "not-an-image.png")
    with open(bad, "w") as f:
        f.write("not a PNG\n")
    expect_operator_error("not-an-image.png", "an unreadable image (imsynth's stderr "
                          "names it)", filepath=bad)
    expect(not plane.material_slots, "the failures left the plane without a material")

    # Into the scratch folder (the errors above went to temporary ones, which the add-on
    # removes when imsynth fails): a test leaves nothing in /tmp.
    result = bpy.ops.imsynth.material_from_image(filepath=a.image, light="scene",
                                                 output_dir=a.work)
    expect(result == {"FINISHED"}, "the operator finishes (%s)" % sorted(result))
    mat = plane.active_material
    expect(mat is not None, "the plane has the material")
    stem = os.path.splitext(os.path.basename(a.image))[0]
    expect(mat.name == stem, "the material is named after the image (%r)" % mat.name)
    expect(mat["imsynth_output"] == os.path.join(a.work, stem),
           "the output went to OUTPUT_FOLDER/<image name>")
    return mat, mat["imsynth_output"]


def check(addon, mat, outdir, plane, work):
    im = addon.import_material
    want = im.build_material(im.load_json(os.path.join(outdir, "material.json")),
                             im.blender_major(), source=outdir)
    n_want = len(want.node_tree.nodes)
    bpy.data.materials.remove(want)
    n = len(mat.node_tree.nodes)
    expect(n == n_want and n > 3, "the material has import_material's %d nodes (%d)"
           % (n_want, n))
    image = bpy.data.images.get(mat["imsynth_compare"])
    expect(image is not None and image.size[0] > 0 and image.size[1] > 0
           and image.packed_file is not None,
           "compare.png is loaded and packed (%r)" % ((tuple(image.size) if image else None),))

    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    # Debian's Blender 3.4 has no OpenImageDenoise, and the factory scene asks for it.
    scene.cycles.use_denoising = False
    scene.render.resolution_x = scene.render.resolution_y = 32
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = os.path.join(work, "render.png")
    bpy.ops.render.render(write_still=True)
    expect(os.path.getsize(os.path.join(work, "render.png")) > 0,
           "a 32 x 32 one-sample Cycles render of the plane runs")


def main(argv):
    p = argparse.ArgumentParser(prog="test_addon.py")
    p.add_argument("--zip", required=True)
    p.add_argument("--image", required=True)
    p.add_argument("--work", required=True)
    p.add_argument("--imsynth")
    p.add_argument("--model")
    p.add_argument("--extra", default="")
    p.add_argument("--outdir")
    a = p.parse_args(argv)
    print("test_addon: Blender %s" % bpy.app.version_string)
    addon = install(a.zip)
    plane = fresh_plane()
    if a.outdir:
        mat, image = addon.import_result(a.outdir, plane, name="predicted")
        expect(plane.active_material == mat, "import_result puts the material on the plane")
        outdir = a.outdir
    else:
        prefs = bpy.context.preferences.addons[MODULE].preferences
        prefs.imsynth_path = a.imsynth
        prefs.model_dir = a.model
        prefs.extra_args = a.extra
        mat, outdir = run_operator(a, plane)
    check(addon, mat, outdir, plane, a.work)


if __name__ == "__main__":
    try:
        main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
    except Fail as e:
        print("test_addon: FAIL: %s" % e, file=sys.stderr)
        sys.exit(1)
    print("test_addon: all ok (Blender %s)" % bpy.app.version_string)
