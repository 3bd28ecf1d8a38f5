#!/bin/sh
# Regenerates the generated seeds of tests/fuzz/corpus/ (the copied and hand-written ones
# too: the whole corpus comes from this script, so it can be remade after a format change).
# Regression inputs (corpus/*/regress-*) are crash reproducers and are never touched.
#
# Usage: sh tests/fuzz/make_corpus.sh [IMSYNTH]   (default build/cli/imsynth, a normal
#        Release build). Needs python3 (no modules) and a C++ compiler with OpenImageIO
#        (a build dependency) for the image seeds. Takes ~20 s.
#
# Seeds are small on purpose: libFuzzer mutates and re-runs each many times a second, and
# the whole corpus stays well under 1 MB.
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
imsynth=${1:-$root/build/cli/imsynth}
c=$root/tests/fuzz/corpus
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
ref=$root/tests/reference
for h in graph params safetensors npy image forest dataset model scene; do
    mkdir -p "$c/$h"
    find "$c/$h" -type f ! -name 'regress-*' -delete
done

# ---- graph: real graphs (every node family of the super-shader, Blender-made ones),
# then hostile variants of the marble example.
cp "$root/assets/examples/marble.json" "$c/graph/marble.json"
cp "$root/assets/supershader.json" "$c/graph/supershader.json"
for g in "$ref"/blender_made/*.json; do cp "$g" "$c/graph/blender_made-$(basename "$g")"; done
m=$c/graph/marble.json
head -c 1500 "$m" > "$c/graph/hostile-truncated.json"
python3 - "$m" "$c/graph" <<'PY'
import json, sys
src, out = sys.argv[1], sys.argv[2]
g = json.load(open(src))
def save(name, obj):
    with open(f"{out}/hostile-{name}.json", "w") as f:
        json.dump(obj, f)
import copy
# A cycle: Multiply's result feeds the Noise Texture's Scale, which feeds Multiply.
c = copy.deepcopy(g)
c["links"].append({"from_node": "Multiply", "from_socket": "Value",
                   "to_node": "Noise Texture", "to_socket": "Scale"})
save("cycle", c)
# A link from a node that does not exist, and to a socket that does not exist.
c = copy.deepcopy(g); c["links"][0]["from_node"] = "Nope"; save("missing-node", c)
c = copy.deepcopy(g); c["links"][0]["to_socket"] = "Nope"; save("missing-socket", c)
# Extreme values: octaves and scales that would take forever or overflow if not clamped.
c = copy.deepcopy(g)
c["nodes"][1]["inputs"] = {"Scale": 1e38, "Detail": 1e30, "Roughness": -1e38, "Distortion": 1e38}
save("extreme-values", c)
# A colour ramp with no elements, and one with unsorted, out-of-range positions.
c = copy.deepcopy(g); c["nodes"][5]["color_ramp"]["elements"] = []; save("ramp-empty", c)
c = copy.deepcopy(g)
c["nodes"][5]["color_ramp"]["elements"] = [{"position": 2.0, "color": [1, 0, 0, 1]},
                                            {"position": -1.0, "color": [0, 1, 0]}]
save("ramp-bad", c)
# Two nodes with one name; a group that instantiates itself.
c = copy.deepcopy(g); c["nodes"][1]["name"] = "Texture Coordinate"; save("duplicate-name", c)
save("self-group", {"format": "imsynth-graph/1", "name": "G",
    "groups": [{"name": "Loop", "nodes": [{"name": "Inner", "type": "ShaderNodeGroup",
                "properties": {"node_tree": "Loop"}}], "links": []}],
    "nodes": [{"name": "Outer", "type": "ShaderNodeGroup", "properties": {"node_tree": "Loop"}}],
    "links": []})
save("wrong-format", {"format": "imsynth-graph/999", "nodes": [], "links": []})
PY
python3 -c "import sys; sys.stdout.write('[' * 5000)" > "$c/graph/hostile-deep-nesting.json"

# ---- params: a sampled parameter set of the super-shader, and broken ones.
"$imsynth" sample --seed 7 -o "$c/params/seed7.json"
python3 - "$c/params/seed7.json" "$c/params" <<'PY'
import json, sys
p = json.load(open(sys.argv[1])); out = sys.argv[2]
k = list(p)
def save(name, text):
    open(f"{out}/hostile-{name}.json", "w").write(text)
save("out-of-range", json.dumps({**p, k[0]: 1.5}))
save("non-finite", json.dumps(p).replace(str(p[k[1]]), "1e999", 1))
save("duplicate", json.dumps(p)[:-1] + ', "%s": 0.5}' % k[2])
save("unknown", json.dumps({**p, "No Such Parameter": 0.5}))
save("missing", json.dumps({x: p[x] for x in k[1:]}))
save("not-number", json.dumps({**p, k[3]: "0.5"}))
save("not-object", "[0.5, 0.25]")
PY

# ---- npy: fixtures of the repository and hand-made headers (every dtype the reader
# converts, versions 1-3, and lies: huge shapes, short data, bad dicts).
cp "$ref/forest/rf_sklearn_r2.npy" "$c/npy/rf_sklearn_r2.npy"
cp "$ref/forest/exact_depth5_importance.npy" "$c/npy/exact_depth5_importance.npy"
cp "$ref/nn_train/colw.npy" "$c/npy/colw.npy"
python3 - "$c/npy" "$tmp/mask.npy" <<'PY'
import struct, sys
out, mask = sys.argv[1], sys.argv[2]
def npy(path, descr, shape, payload, version=1, fortran="False", header=None):
    hdr = header or "{'descr': '%s', 'fortran_order': %s, 'shape': %s, }" % (descr, fortran, shape)
    pre = 10 if version == 1 else 12
    pad = (-(pre + len(hdr) + 1)) % 64
    hdr = (hdr + " " * pad + "\n").encode("latin-1" if version < 3 else "utf-8")
    with open(path, "wb") as f:
        f.write(b"\x93NUMPY" + bytes([version, 0]))
        f.write(struct.pack("<H" if version == 1 else "<I", len(hdr)))
        f.write(hdr + payload)
# The descriptor mask used by the model seed (16 feature indices).
npy(mask, "<i8", "(16,)", struct.pack("<16q", *[i * 997 for i in range(16)]))
d = f"{out}/"
npy(d + "f2_2x3.npy", "<f2", "(2, 3)", struct.pack("<6e", 0, 1, -2, 0.5, 65504, -0.0))
npy(d + "f8_3.npy", "<f8", "(3,)", struct.pack("<3d", 1.5, -2.25, 1e300))
npy(d + "i4_2x2_v2.npy", "<i4", "(2, 2)", struct.pack("<4i", 1, -2, 3, 2**31 - 1), version=2)
npy(d + "u8_2.npy", "<u8", "(2,)", struct.pack("<2Q", 0, 2**64 - 1), version=3)
npy(d + "u1_scalar.npy", "|u1", "()", b"\x07")
npy(d + "b1_4.npy", "|b1", "(4,)", b"\x00\x01\x01\x00")
npy(d + "i2_empty.npy", "<i2", "(0, 5)", b"")
npy(d + "hostile-fortran.npy", "<f4", "(2, 2)", struct.pack("<4f", 1, 2, 3, 4), fortran="True")
npy(d + "hostile-big-endian.npy", ">f4", "(2,)", struct.pack(">2f", 1, 2))
npy(d + "hostile-3d.npy", "<f4", "(1, 1, 2)", struct.pack("<2f", 1, 2))
npy(d + "hostile-huge-shape.npy", "<f4", "(4611686018427387904, 4)", b"\0" * 16)
npy(d + "hostile-overflow-shape.npy", "<f4", "(4294967296, 4294967297)", b"\0" * 16)
npy(d + "hostile-short-data.npy", "<f4", "(10, 10)", b"\0" * 16)
npy(d + "hostile-no-descr.npy", "", "", b"", header="{'fortran_order': False, 'shape': (1,), }")
npy(d + "hostile-unterminated.npy", "", "", b"", header="{'descr': '<f4', 'shape': (1,")
with open(d + "hostile-header-length.npy", "wb") as f:  # header longer than the file
    f.write(b"\x93NUMPY\x01\x00\xff\xff{'descr'")
PY

# ---- safetensors: a small training checkpoint of the repository, hand-made files
# (every dtype, metadata) and lying headers.
cp "$ref/nn_train/sgd_clip_step/init.safetensors" "$c/safetensors/checkpoint_init.safetensors"
python3 - "$c/safetensors" <<'PY'
import json, struct, sys
out = sys.argv[1] + "/"
def st(name, header, data, length=None):
    h = header if isinstance(header, bytes) else json.dumps(header).encode()
    with open(out + name, "wb") as f:
        f.write(struct.pack("<Q", len(h) if length is None else length) + h + data)
st("dtypes.safetensors",
   {"__metadata__": {"imsynth.arch": "mlp", "note": "seed"},
    "a": {"dtype": "F32", "shape": [2, 2], "data_offsets": [0, 16]},
    "b": {"dtype": "F16", "shape": [3], "data_offsets": [16, 22]},
    "c": {"dtype": "BF16", "shape": [], "data_offsets": [22, 24]}},
   struct.pack("<4f", 1, 2, 3, 4) + struct.pack("<3e", 1, -1, 0.5) + b"\x80\x3f")
st("empty.safetensors", {}, b"")
t = {"x": {"dtype": "F32", "shape": [2], "data_offsets": [0, 8]}}
st("hostile-length-past-end.safetensors", t, b"\0" * 8, length=1 << 40)
st("hostile-length-zero.safetensors", t, b"\0" * 8, length=0)
st("hostile-overlap.safetensors",
   {"x": {"dtype": "F32", "shape": [2], "data_offsets": [0, 8]},
    "y": {"dtype": "F32", "shape": [2], "data_offsets": [4, 12]}}, b"\0" * 12)
st("hostile-shape-overflow.safetensors",
   {"x": {"dtype": "F32", "shape": [4611686018427387904, 4], "data_offsets": [0, 0]}}, b"")
st("hostile-range-past-data.safetensors",
   {"x": {"dtype": "F32", "shape": [2], "data_offsets": [0, 8]}}, b"\0" * 4)
st("hostile-bad-dtype.safetensors",
   {"x": {"dtype": "I64", "shape": [1], "data_offsets": [0, 8]}}, b"\0" * 8)
st("hostile-negative.safetensors",
   {"x": {"dtype": "F32", "shape": [-1], "data_offsets": [-4, 0]}}, b"\0" * 4)
st("hostile-not-json.safetensors", b"{\"x\": [1, 2", b"")
st("hostile-checkpoint-arch.safetensors",
   {"__metadata__": {"imsynth.arch": "4-1000000000-2", "imsynth.heads": "[]", "imsynth.y_cols": "2"},
    "net.0.weight": {"dtype": "F32", "shape": [1, 1], "data_offsets": [0, 4]}}, b"\0" * 4)
PY

# ---- image: small files in every format the tool reads (make_images.cpp), a stored EXR
# reference, and broken ones. The first byte selects the extension (fuzz_image.c).
c++ -std=c++17 -O1 -o "$tmp/make_images" "$root/tests/fuzz/make_images.cpp" \
    $(pkg-config --cflags --libs OpenImageIO)
"$tmp/make_images" "$c/image"
{ printf '\003'; cat "$ref/nodes/voronoi_scale0_position/blender-4.3.exr"; } > "$c/image/blender_ref.exr"
head -c 60 "$c/image/rgba8.png" > "$c/image/hostile-truncated.png"
head -c 200 "$c/image/rgb.jpg" > "$c/image/hostile-truncated.jpg"
python3 - "$c/image" <<'PY'
import struct, sys, zlib
out = sys.argv[1] + "/"
def chunk(t, d):
    return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
# A PNG whose header claims 16384 x 16384 (the reader's limit) with 1 row of data, and one
# beyond the limit: neither may allocate gigabytes before finding the data short.
for name, w, h in (("hostile-huge.png", 16384, 16384), ("hostile-too-big.png", 1 << 20, 1)):
    ihdr = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    idat = zlib.compress(b"\0" + b"\x80" * 3 * min(w, 64))
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")
    open(out + name, "wb").write(b"\0" + png)
# A TIFF header claiming a 1e9 x 1e9 strip image with no strips.
tif = b"II*\0" + struct.pack("<I", 8) + struct.pack("<H", 3)
tif += struct.pack("<HHII", 256, 4, 1, 1000000000) + struct.pack("<HHII", 257, 4, 1, 1000000000)
tif += struct.pack("<HHII", 258, 3, 1, 8) + struct.pack("<I", 0)
open(out + "hostile-huge.tif", "wb").write(b"\2" + tif)
# EXR magic with nothing after it.
open(out + "hostile-magic-only.exr", "wb").write(b"\3" + b"\x76\x2f\x31\x01\x02\0\0\0")
PY

# ---- scene: the two bundled scenes and broken ones.
cp "$root/assets/scene.json" "$c/scene/scene.json"
cp "$root/assets/scene-flash.json" "$c/scene/scene-flash.json"
python3 - "$root/assets/scene.json" "$c/scene" "$tmp/small-scene.json" <<'PY'
import copy, json, sys
s = json.load(open(sys.argv[1])); out = sys.argv[2] + "/"
def save(name, obj): json.dump(obj, open(out + "hostile-" + name + ".json", "w"))
x = copy.deepcopy(s); x["resolution"] = [0, -5]; save("resolution", x)
x = copy.deepcopy(s); x["resolution"] = [1 << 31, 1 << 31]; save("resolution-huge", x)
x = copy.deepcopy(s); x["objects"][0]["faces"] = [[0, 1, 7]]; save("face-index", x)
x = copy.deepcopy(s); x["camera"]["forward"] = [0, 0, 0]; save("camera-zero", x)
x = copy.deepcopy(s); x["lights"][0]["power"] = -1e39; save("light-power", x)
x = copy.deepcopy(s); x["lights"] = []; save("no-lights", x)
# The 8 x 8 scene the dataset seeds are rendered with (their stored renders stay tiny).
x = copy.deepcopy(s); x["resolution"] = [8, 8]; json.dump(x, open(sys.argv[3], "w"))
PY

# ---- forest: two tiny forests fitted on the scikit-learn fixture (exact and binned).
"$imsynth" forest fit --x "$ref/forest/rf_X_train.npy" --y "$ref/forest/rf_Y_train.npy" \
    -o "$c/forest/rf_2trees.forest" --trees 2 --max-depth 3 --split exact --threads 1 > /dev/null 2>&1
"$imsynth" forest fit --x "$ref/forest/exact_X_train.npy" --y "$ref/forest/exact_Y_train.npy" \
    -o "$c/forest/exact_binned.forest" --trees 1 --max-depth 2 --threads 1 > /dev/null 2>&1
head -c 100 "$c/forest/rf_2trees.forest" > "$c/forest/hostile-truncated.forest"
python3 - "$c/forest" <<'PY'
import struct, sys
out = sys.argv[1] + "/"
# Header (magic, version 1, 0, d, k, trees) claiming 2^24 trees in a short file; then one
# tree of 1 node whose children point back at itself (a cycle if it were accepted).
hdr = b"IMSYFRST" + struct.pack("<IIQQQ", 1, 0, 4, 1, 1 << 24)
open(out + "hostile-many-trees.forest", "wb").write(hdr + b"\0" * 64)
node = struct.pack("<iiiidddd", 0, 0, 0, 1, 0.5, 1, 0, 0)
cyc = b"IMSYFRST" + struct.pack("<IIQQQ", 1, 0, 4, 1, 1) + struct.pack("<Q", 1) + node
cyc += struct.pack("<f", 1.0) + b"\0" * 8
open(out + "hostile-cycle.forest", "wb").write(cyc)
PY

# ---- dataset: datagen's files at the draft preset on the 8 x 8 scene (the stored renders
# are 8 x 8: a 256 x 256 one is half a megabyte), with a PNG render, an EXR render, and
# MobileNetV2 descriptors cut by a 16-feature mask; then a truncated one.
"$imsynth" datagen --out "$c/dataset/png.sqlite" --count 2 --preset draft --descriptor none \
    --scene "$tmp/small-scene.json" --threads 1 --quiet
"$imsynth" datagen --out "$c/dataset/exr.sqlite" --count 1 --preset draft --descriptor none \
    --images exr --scene "$tmp/small-scene.json" --threads 1 --quiet
"$imsynth" datagen --out "$tmp/model-data.sqlite" --count 12 --preset draft --images none \
    --descriptor-mask "$tmp/mask.npy" --threads 1 --quiet
cp "$tmp/model-data.sqlite" "$c/dataset/descriptors.sqlite"
head -c 8192 "$c/dataset/png.sqlite" > "$c/dataset/hostile-truncated.sqlite"

# ---- model: a tiny model fitted on the 12 masked-descriptor samples, its four files
# joined with fuzz_model.c's separator line; then the same with a part missing.
# predictor_load refuses models of masked descriptors (not supported), which would stop
# every input early, and an unmasked model's transform is 600 KB (38,808 features). So
# the seed drops the mask's digest from model.json: the loader then sees a consistent
# 16-feature model and the fuzzer reaches the tensor checks and prediction.
"$imsynth" fit-predictor --dataset "$tmp/model-data.sqlite" --components 4 --hidden 8 \
    --batch 4 --val-fraction 0.2 --epochs 2 --half --catalogue 4 --threads 1 --quiet \
    -o "$tmp/model"
python3 - "$tmp/model/model.json" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
open(sys.argv[1], "w").write(re.sub(r',\s*"mask_sha256":\s*"[0-9a-f]*"', "", text))
PY
sep='
--imsynth-fuzz-next-file--
'
join() {
    first=1
    for f in "$@"; do
        [ $first -eq 1 ] || printf '%s' "$sep"
        first=0
        cat "$tmp/model/$f"
    done
}
join model.json transform.safetensors network.safetensors catalogue.safetensors \
    > "$c/model/tiny.model"
join model.json transform.safetensors network.safetensors > "$c/model/hostile-no-catalogue.model"
join model.json catalogue.safetensors network.safetensors transform.safetensors \
    > "$c/model/hostile-swapped.model"

# ---- dictionaries (libFuzzer -dict, used by run.sh): the words of the JSON formats, so
# mutations can write a node type or a key rather than guess it byte by byte.
python3 - "$root" <<'PY'
import json, re, sys, glob
root = sys.argv[1]
def words(paths):
    out = set()
    def walk(o):
        if isinstance(o, dict):
            for k, v in o.items():
                out.add(k); walk(v)
        elif isinstance(o, list):
            for v in o: walk(v)
        elif isinstance(o, str) and len(o) < 40:
            out.add(o)
    for p in paths:
        walk(json.load(open(p)))
    return out
def write(name, ws):
    with open(f"{root}/tests/fuzz/{name}.dict", "w") as f:
        f.write(f"# libFuzzer dictionary for fuzz_{name}: written by make_corpus.sh\n")
        for w in sorted(ws):
            f.write(json.dumps(json.dumps(w)) + "\n")
g = words([f"{root}/assets/supershader.json", f"{root}/assets/examples/marble.json"]
          + glob.glob(f"{root}/tests/reference/blender_made/*.json"))
for src in glob.glob(f"{root}/shadergraph/*.c") + glob.glob(f"{root}/shadergraph/kernels/*.c"):
    g |= set(re.findall(r'"(ShaderNode[A-Za-z]+)"', open(src).read()))
write("graph", g)
write("scene", words([f"{root}/assets/scene.json", f"{root}/assets/scene-flash.json"]))
PY

du -sh "$c"
