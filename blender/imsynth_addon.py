"""imsynth add-on for Blender 3.4 and 4.x: "Material from image..." in the Shader Editor.

The Shader Editor's Add menu gets an entry that asks for an image file, runs

    imsynth predict IMAGE -o OUTDIR [--model DIR] [--light L] [extra arguments]

and puts the resulting material (OUTDIR/material.json, built by import_material.py) on the
active object, with OUTDIR/compare.png (input | our render | the loss curve) loaded as an
image and shown in an Image Editor. docs/blender-addon.md says how to install and use it.

This file is the package's __init__.py in the zip blender/make_addon_zip.py writes, beside
import_material.py and compat_noise.py: the add-on builds materials with the same code
as the command-line importer, so a material looks the same whichever way it came in.

Where things can go wrong, the error names the file and, when imsynth failed, shows
imsynth's own message: a user sees "photo.png: smaller than 32 x 32", not "exit 1".
"""

bl_info = {
    "name": "imsynth: Material from image",
    "author": "imsynth",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Shader Editor > Add > Material from image...",
    "description": "Turns a photo of a surface into a procedural material (imsynth predict)",
    "category": "Material",
}

import os
import shlex
import shutil
import subprocess
import tempfile

import bpy
from bpy.props import BoolProperty, EnumProperty, StringProperty

from . import import_material

ADDON = __name__
# Lines of imsynth's stderr shown in an error report: its message is the last lines; the
# progress lines before it say how far it got.
STDERR_TAIL = 12


# ---- preferences ----------------------------------------------------------------------

class IMSYNTH_AddonPreferences(bpy.types.AddonPreferences):
    bl_idname = ADDON

    imsynth_path: StringProperty(
        name="imsynth executable",
        description="Path to the imsynth program (empty: $IMSYNTH, else imsynth on PATH)",
        subtype="FILE_PATH", default="")
    model_dir: StringProperty(
        name="Model folder",
        description="A model from imsynth fit-predictor (empty: imsynth's bundled model)",
        subtype="DIR_PATH", default="")
    extra_args: StringProperty(
        name="Extra arguments",
        description="More imsynth predict options, e.g. --refine 16 --final-preset datagen",
        default="")

    def draw(self, _context):
        col = self.layout.column()
        col.prop(self, "imsynth_path")
        col.prop(self, "model_dir")
        col.prop(self, "extra_args")


def preferences(context):
    return context.preferences.addons[ADDON].preferences


def find_imsynth(prefs):
    """The imsynth executable: the preference, else $IMSYNTH, else imsynth on PATH.
    Raises RuntimeError saying where it looked."""
    if prefs.imsynth_path:
        path = bpy.path.abspath(prefs.imsynth_path)
        if not (os.path.isfile(path) and os.access(path, os.X_OK)):
            raise RuntimeError("%s: not an executable (the imsynth path in the add-on's "
                               "preferences)" % path)
        return path
    env = os.environ.get("IMSYNTH")
    if env:
        if not (os.path.isfile(env) and os.access(env, os.X_OK)):
            raise RuntimeError("%s: not an executable ($IMSYNTH)" % env)
        return env
    found = shutil.which("imsynth")
    if not found:
        raise RuntimeError("imsynth not found: set its path in Edit > Preferences > "
                           "Add-ons > imsynth, or $IMSYNTH, or put it on PATH")
    return found


def predict_command(exe, image, outdir, prefs, light):
    """imsynth predict's argument list. The add-on's own choices come before the extra
    arguments, so a user's --light or --model there wins (imsynth takes the last)."""
    cmd = [exe, "predict", image, "-o", outdir, "--light", light]
    if prefs.model_dir:
        # Blender's folder picker ends paths with a separator; imsynth's messages name the
        # folder as given, and read better without it.
        cmd += ["--model", bpy.path.abspath(prefs.model_dir).rstrip("/\\") or "/"]
    extra = shlex.split(prefs.extra_args)
    # The material is predicted under the semantics of the Blender that will render it
    # (3.x's Voronoi has no octaves, its Principled BSDF differs); imsynth's default is 4.
    if "--blender" not in extra:
        cmd += ["--blender", "3" if import_material.blender_major() < 4 else "4"]
    return cmd + extra


# ---- the result into the scene ----------------------------------------------------------

def _new_ids():
    return set(bpy.data.materials) | set(bpy.data.node_groups)


def import_result(outdir, obj, name=None):
    """Build OUTDIR/material.json as a material named `name` (default: the material's own)
    on mesh object `obj` (into its active slot; a slot is added if it has none) and load
    OUTDIR/compare.png as an image. Returns (material, image). Raises RuntimeError naming
    the file at fault; a material half built is removed."""
    path = os.path.join(outdir, "material.json")
    before = _new_ids()
    try:
        data = import_material.load_json(path)
        mat = import_material.build_material(data, import_material.blender_major(),
                                             source=path, name=name)
    except import_material.ImportError_ as e:
        # build_material stops at the first node it cannot build; what it made so far
        # (groups, the material) would linger as orphans with confusing names.
        for block in _new_ids() - before:
            coll = bpy.data.materials if isinstance(block, bpy.types.Material) \
                else bpy.data.node_groups
            coll.remove(block)
        raise RuntimeError(str(e))
    if len(obj.material_slots) == 0:
        obj.data.materials.append(mat)
    else:
        obj.material_slots[obj.active_material_index].material = mat
    mat["imsynth_output"] = outdir

    compare = os.path.join(outdir, "compare.png")
    try:
        image = bpy.data.images.load(compare, check_existing=False)
    except RuntimeError as e:
        raise RuntimeError("%s: cannot load (%s)" % (compare, e))
    image.name = "%s compare" % mat.name
    # Packed into the .blend: the output folder may be a temporary one.
    image.pack()
    mat["imsynth_compare"] = image.name
    return mat, image


def show_image(context, image):
    """Show `image` in an open Image Editor, else in a new window's Image Editor. Returns
    where it went, or None (background mode, or the window could not be made: the image
    is still loaded, and a user can pick it in any Image Editor)."""
    wm = context.window_manager
    for window in wm.windows:
        for area in window.screen.areas:
            if area.type == "IMAGE_EDITOR":
                area.spaces.active.image = image
                area.tag_redraw()
                return "the open Image Editor"
    if bpy.app.background or context.window is None:
        return None
    try:
        # window_new opens a window holding one area (of the biggest area's type):
        # turning that area into an Image Editor needs no layout of ours.
        before = set(wm.windows[:])
        bpy.ops.wm.window_new()
        new = [w for w in wm.windows if w not in before]
        if not new:
            return None
        area = new[0].screen.areas[0]
        area.type = "IMAGE_EDITOR"
        area.spaces.active.image = image
        return "a new window"
    except (RuntimeError, AttributeError, IndexError):
        return None


# ---- the operator -------------------------------------------------------------------------

LIGHTS = [
    ("scene", "Point light", "The photo was lit like imsynth's scene: a light above, "
     "off-centre"),
    ("flash", "Flash", "The photo was taken with a flash at the camera"),
    ("auto", "Try both", "Score the candidates under both lights and keep the better "
     "(about 10% more time)"),
]


def _tail(path, lines):
    try:
        with open(path, errors="replace") as f:
            return "".join(f.readlines()[-lines:]).strip()
    except OSError:
        return ""


class IMSYNTH_OT_material_from_image(bpy.types.Operator):
    """Predict a procedural material from an image file with imsynth and put it on the
    active object"""
    bl_idname = "imsynth.material_from_image"
    bl_label = "Material from image..."
    bl_options = {"REGISTER", "UNDO"}

    filepath: StringProperty(name="Image", subtype="FILE_PATH")
    filter_image: BoolProperty(default=True, options={"HIDDEN", "SKIP_SAVE"})
    filter_folder: BoolProperty(default=True, options={"HIDDEN", "SKIP_SAVE"})
    light: EnumProperty(name="Light", items=LIGHTS, default="auto",
                        description="How the photo was lit (imsynth predict --light)")
    output_dir: StringProperty(
        name="Output folder", subtype="DIR_PATH", default="",
        description="Keep imsynth's output in FOLDER/<image name>/ (empty: a new "
        "temporary folder)")

    def draw(self, _context):
        col = self.layout.column()
        col.prop(self, "light")
        col.prop(self, "output_dir")

    @staticmethod
    def _target(context):
        obj = context.view_layer.objects.active
        if obj is None or obj.type != "MESH":
            raise RuntimeError("Material from image needs an active mesh object (%s)"
                               % ("none is active" if obj is None else
                                  "%r is a %s" % (obj.name, obj.type.lower())))
        return obj

    def invoke(self, context, _event):
        # Refuse before the file browser, not after the user has picked a file.
        try:
            self._target(context)
        except RuntimeError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        try:
            return self._start(context)
        except RuntimeError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}

    def _start(self, context):
        obj = self._target(context)
        image = bpy.path.abspath(self.filepath)
        if not os.path.isfile(image):
            raise RuntimeError("%s: no such image file" % (image or "(no file chosen)"))
        prefs = preferences(context)
        exe = find_imsynth(prefs)
        stem = os.path.splitext(os.path.basename(image))[0]
        # The work folder holds imsynth's stderr and, without an output folder, OUTDIR:
        # predict writes OUTDIR whole and refuses a folder of other files, so OUTDIR is a
        # subfolder it can create (or replace, when it holds an earlier result).
        if self.output_dir and not os.path.isdir(bpy.path.abspath(self.output_dir)):
            raise RuntimeError("%s: output folder does not exist"
                               % bpy.path.abspath(self.output_dir))
        self._work = tempfile.mkdtemp(prefix="imsynth-")
        parent = bpy.path.abspath(self.output_dir) if self.output_dir else self._work
        self._outdir = os.path.join(parent, stem)
        self._image, self._stem, self._obj_name = image, stem, obj.name
        self._log = os.path.join(self._work, "imsynth-stderr.txt")
        cmd = predict_command(exe, image, self._outdir, prefs, self.light)
        print("imsynth add-on: %s" % " ".join(shlex.quote(c) for c in cmd))
        # stderr to a file, not a pipe: a pipe nobody reads while imsynth runs fills up
        # and stalls it; the file is read when it ends (and for the status line).
        with open(self._log, "wb") as log:
            try:
                self._proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=log,
                                              stderr=log)
            except OSError as e:
                raise RuntimeError("%s: cannot run (%s)" % (exe, e.strerror))
        if bpy.app.background or context.window is None:
            # No events come in background mode (it still has a window in the context)
            # nor without a window: wait for imsynth here.
            self._proc.wait()
            return self._finish(context)
        # With a window, predict runs while Blender stays usable; a timer polls it.
        self._timer = context.window_manager.event_timer_add(0.25, window=context.window)
        context.window_manager.modal_handler_add(self)
        self._status(context, "started")
        return {"RUNNING_MODAL"}

    def _status(self, context, text):
        if context.workspace is not None:
            context.workspace.status_text_set(
                None if text is None else
                "imsynth predict %s: %s   (Esc cancels)" % (self._stem, text))

    def _stop_polling(self, context):
        context.window_manager.event_timer_remove(self._timer)
        self._status(context, None)

    def modal(self, context, event):
        if event.type == "ESC" and event.value == "PRESS":
            self._proc.terminate()
            self._proc.wait()
            self._stop_polling(context)
            shutil.rmtree(self._work, ignore_errors=True)
            self.report({"WARNING"}, "imsynth predict %s: cancelled" % self._image)
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        if self._proc.poll() is None:
            last = _tail(self._log, 1)
            self._status(context, last.replace("predict: ", "") or "running")
            return {"PASS_THROUGH"}
        self._stop_polling(context)
        try:
            return self._finish(context)
        except RuntimeError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}

    def _finish(self, context):
        rc = self._proc.returncode
        if rc != 0:
            msg = _tail(self._log, STDERR_TAIL) or "(no message)"
            # predict leaves no OUTDIR when it fails: the work folder holds only the log.
            shutil.rmtree(self._work, ignore_errors=True)
            raise RuntimeError("imsynth predict failed on %s (exit %d):\n%s"
                               % (self._image, rc, msg))
        obj = bpy.data.objects.get(self._obj_name)
        if obj is None or obj.type != "MESH":
            raise RuntimeError("the object %r is gone; the material is in %s"
                               % (self._obj_name, self._outdir))
        mat, image = import_result(self._outdir, obj, name=self._stem)
        mat["imsynth_source"] = self._image
        shown = show_image(context, image)
        if not self._outdir.startswith(self._work + os.sep):
            # Only imsynth's stderr is left in the work folder: the output is elsewhere.
            shutil.rmtree(self._work, ignore_errors=True)
        self.report({"INFO"}, "imsynth: material %r on %r; comparison image %r%s; files in %s"
                    % (mat.name, obj.name, image.name,
                       " shown in " + shown if shown else "", self._outdir))
        return {"FINISHED"}


def menu_entry(self, context):
    if getattr(context.space_data, "tree_type", None) != "ShaderNodeTree":
        return
    self.layout.separator()
    self.layout.operator_context = "INVOKE_REGION_WIN"
    self.layout.operator(IMSYNTH_OT_material_from_image.bl_idname, icon="IMAGE_DATA")


CLASSES = (IMSYNTH_AddonPreferences, IMSYNTH_OT_material_from_image)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.NODE_MT_add.append(menu_entry)


def unregister():
    bpy.types.NODE_MT_add.remove(menu_entry)
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
