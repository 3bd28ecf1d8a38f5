"""The imsynth add-on's interactive path, in a Blender with a window (a virtual display:
tests/cli/addon.sh runs it under xvfb-run when there is one):

    BLENDER_USER_SCRIPTS=DIR xvfb-run -a blender --factory-startup \\
        -P tests/blender/test_addon_ui.py -- --zip Z --image IMAGE --work DIR \\
        --imsynth BIN --model DIR --extra "ARGS"

Headless (test_addon.py) the operator waits for imsynth; with a window it returns at
once, polls imsynth from a timer while Blender stays usable, and shows compare.png in an
Image Editor, in a new window when none is open. That is what this checks: the menu entry
is in the Add menu, the operator goes modal, the material arrives on the plane and the
image is on screen. Blender runs the checks from timers (a -P script runs before the
window exists) and quits; the last line says "test_addon_ui: all ok" or
"test_addon_ui: FAIL: ...", which the shell reads (a quit from a timer exits 0).
"""

import os
import sys
import time

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import test_addon as t  # noqa: E402  (the install and checks of the headless test)

TIMEOUT = 120.0  # seconds for imsynth predict with the test's fast options


def parse():
    import argparse
    p = argparse.ArgumentParser(prog="test_addon_ui.py")
    for k in ("--zip", "--image", "--work", "--imsynth", "--model"):
        p.add_argument(k, required=True)
    p.add_argument("--extra", default="")
    return p.parse_args(sys.argv[sys.argv.index("--") + 1:])


A = parse()
STATE = {}


def done(failure=None):
    if failure:
        print("test_addon_ui: FAIL: %s" % failure, flush=True)
    else:
        print("test_addon_ui: all ok (Blender %s)" % bpy.app.version_string, flush=True)
    bpy.ops.wm.quit_blender()


def guarded(step):
    """A timer callback that ends the test on a failure or an exception."""
    def run():
        try:
            return step()
        except t.Fail as e:
            done(str(e))
        except Exception as e:  # an unexpected error is a failure too, with its trace
            import traceback
            traceback.print_exc()
            done("%s: %s" % (type(e).__name__, e))
        return None
    return run


def start():
    addon = t.install(A.zip)
    prefs = bpy.context.preferences.addons[t.MODULE].preferences
    prefs.imsynth_path, prefs.model_dir, prefs.extra_args = A.imsynth, A.model, A.extra
    t.expect(addon.menu_entry in bpy.types.NODE_MT_add._dyn_ui_initialize(),
             "the entry is in the node editors' Add menu")

    win = bpy.context.window_manager.windows[0]
    areas = sorted(win.screen.areas, key=lambda a: a.width * a.height, reverse=True)
    view3d = [a for a in areas if a.type == "VIEW_3D"][0]
    for ob in list(bpy.data.objects):
        if ob.type == "MESH":
            bpy.data.objects.remove(ob, do_unlink=True)
    with bpy.context.temp_override(window=win, area=view3d):
        bpy.ops.mesh.primitive_plane_add(size=2.0)
    # A Shader Editor to call from, and no Image Editor: the image must open a window.
    editor = [a for a in areas if a.type != "VIEW_3D"][0]
    editor.type = "NODE_EDITOR"
    editor.ui_type = "ShaderNodeTree"
    for a in win.screen.areas:
        if a.type == "IMAGE_EDITOR":
            a.type = "OUTLINER"
    STATE["windows"] = len(bpy.context.window_manager.windows)
    with bpy.context.temp_override(window=win, area=editor):
        r = bpy.ops.imsynth.material_from_image("EXEC_DEFAULT", filepath=A.image,
                                                output_dir=A.work)
    t.expect(r == {"RUNNING_MODAL"}, "with a window the operator goes modal (%s)" % sorted(r))
    STATE["t0"] = time.time()
    bpy.app.timers.register(guarded(wait), first_interval=0.5)
    return None


def wait():
    plane = bpy.data.objects.get("Plane")
    mat = plane.active_material if plane else None
    if mat is None:
        if time.time() - STATE["t0"] > TIMEOUT:
            raise t.Fail("no material after %.0f s" % TIMEOUT)
        return 0.5
    t.expect(mat.name == os.path.splitext(os.path.basename(A.image))[0],
             "the material %r arrived on the plane" % mat.name)
    wm = bpy.context.window_manager
    shown = [a.spaces.active.image.name for w in wm.windows for a in w.screen.areas
             if a.type == "IMAGE_EDITOR" and a.spaces.active.image is not None]
    t.expect(shown == [mat["imsynth_compare"]] and len(wm.windows) == STATE["windows"] + 1,
             "compare.png is shown in a new window's Image Editor (%s)" % shown)
    done()
    return None


# The window exists once the event loop runs: start from the first timer.
bpy.app.timers.register(guarded(start), first_interval=1.0)
