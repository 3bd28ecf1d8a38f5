"""Which imsynth binary the Python tooling under tests/ runs (plain python3).

find_imsynth(given): `given` (a --imsynth option) if set, else $IMSYNTH, else the newest
build*/cli/imsynth under the repository root (CMake build trees), else `imsynth` on PATH;
exits with a message naming where it looked if there is none.
"""
import glob
import os
import shutil

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def find_imsynth(given=None, prog="imsynth tooling"):
    if given:
        return given
    if os.environ.get("IMSYNTH"):
        return os.environ["IMSYNTH"]
    found = sorted(glob.glob(os.path.join(REPO, "build*", "cli", "imsynth")),
                   key=os.path.getmtime, reverse=True)
    if found:
        return found[0]
    on_path = shutil.which("imsynth")
    if on_path:
        return on_path
    raise SystemExit("%s: no imsynth binary: pass --imsynth PATH or set IMSYNTH "
                     "(looked in %s/build*/cli and on PATH)" % (prog, REPO))
