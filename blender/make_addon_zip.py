#!/usr/bin/env python3
"""Write the installable Blender add-on: imsynth_addon.zip.

    python3 blender/make_addon_zip.py [-o imsynth_addon.zip]

The zip holds one package folder, imsynth_addon/: __init__.py (blender/imsynth_addon.py)
and the two modules it builds materials with, import_material.py and compat_noise.py,
copied as they are so the add-on and the command-line importer are the same code.
Blender's Edit > Preferences > Add-ons > Install takes the zip as it is.

The zip is deterministic (fixed timestamps and permissions, a fixed order): the same
sources give the same bytes, so a rebuilt zip that differs has a reason.
Plain python3, standard library only.
"""

import argparse
import os
import sys
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))
PACKAGE = "imsynth_addon"
# (name in the package, file in blender/)
FILES = (("__init__.py", "imsynth_addon.py"),
         ("import_material.py", "import_material.py"),
         ("compat_noise.py", "compat_noise.py"))
# zip's epoch is 1980; any fixed date will do.
TIMESTAMP = (1980, 1, 1, 0, 0, 0)


def write_zip(out):
    tmp = out + ".tmp"
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for name, src in FILES:
            path = os.path.join(HERE, src)
            try:
                with open(path, "rb") as f:
                    data = f.read()
            except OSError as e:
                sys.exit("make_addon_zip: %s: %s" % (path, e.strerror))
            info = zipfile.ZipInfo("%s/%s" % (PACKAGE, name), date_time=TIMESTAMP)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            info.create_system = 3  # Unix, whatever the machine: the same bytes anywhere
            z.writestr(info, data)
    os.replace(tmp, out)


def main():
    p = argparse.ArgumentParser(prog="make_addon_zip.py", description=__doc__.split("\n")[0])
    p.add_argument("-o", "--output", default="imsynth_addon.zip")
    a = p.parse_args()
    write_zip(a.output)
    print("make_addon_zip: wrote %s" % a.output)


if __name__ == "__main__":
    main()
