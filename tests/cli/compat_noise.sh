#!/bin/sh
# blender/compat_noise.py without Blender (plain Python): a 4.x Noise Texture written for
# Blender 3.4 as a Musgrave (Dimension = -ln Roughness / ln Lacunarity, stored as a float)
# and read back by export_material.py (musgrave_roughness_for_export) gives back the
# Roughness it was written with, not Lacunarity^-Dimension recomputed (0.45 -> 0.45000002
# failed `make blender-roundtrip` by one ulp); and the value written back translates to the
# same float Dimension, so it builds the same 3.4 node.
# Usage: compat_noise.sh IMSYNTH REPO_ROOT
imsynth=$1
root=$2
. "$root/tests/cli/lib/harness.sh"
: "$imsynth"

python3 - "$root/blender" << 'PY'
import random, sys
sys.path.insert(0, sys.argv[1])
from compat_noise import _f32, musgrave_dimension, musgrave_roughness_for_export, _musgrave_roughness
rng = random.Random(1)
cases = [(r / 100.0, lac) for r in range(1, 101) for lac in (2.0, 2.5, 3.0)]
cases += [(round(rng.uniform(0.01, 1.0), 3), round(rng.uniform(1.5, 2.7), 2)) for _ in range(300)]
ulp_off = 0
for r, lac in cases:
    dim = _f32(musgrave_dimension(r, lac))
    back = musgrave_roughness_for_export(dim, lac)
    assert back == r, (r, lac, dim, back)
    assert _f32(musgrave_dimension(back, lac)) == dim
    ulp_off += _musgrave_roughness(dim, lac) != _f32(r)
# Recomputed, many come back a float32 ulp or more off: what the snapping is for.
assert ulp_off > 50, ulp_off
print("%d cases, %d of them off as float32 when recomputed" % (len(cases), ulp_off))
PY
check "Musgrave Roughness read back as written, same float Dimension" 0 $?
finish
