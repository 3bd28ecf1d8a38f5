#!/usr/bin/python3
"""PyTorch oracle for nn's MobileNetV2 Gram descriptor (tests/unit/test_nn_mobilenet.c).

    /usr/bin/python3 tests/reference/nn/mobilenetv2/make_fixture.py

An independent forward of the committed converted weights
(assets/mobilenetv2/mobilenetv2_block10.safetensors), in float64 with torch's conv2d:
Conv1 3x3 stride 2 after zero padding (0,1) rows and columns (Keras' correct_pad for
even sizes), per block an optional 1x1 expand + ReLU6, a depthwise 3x3 (groups = C;
padding 1 at stride 1, (0,1) at stride 2) + ReLU6, a 1x1 projection, plus the input when
stride 1 and cin == cout. Grams G = F F^T / (H W), upper triangle with diagonal row by
row, concatenated in tap order (then the second scale).

Writes, beside this script:
  expected_default.npy  (2, 77616) float32: the default taps (conv1, block_1_expand,
      block_3_expand, block_6_expand, block_10_project) at 224 and at 112 (the 224 input
      box-averaged 2x2), of tests/reference/nn/images_u8.npy's two 256x256 images taken
      as LINEAR light: image 0 = u8/255, image 1 = u8/255 * 1.5 - 0.25 (out of [0,1]:
      the clamp is exercised); preprocessing is the descriptor's: clamp to [0,1],
      sRGB-encode, centre crop rows/cols 16..239, values in [0,1].
  expected_taps64.npy   (1, N) float32: ten taps covering every tap kind, both strides
      and the residual blocks (TAPS64 below), of a 64x64 input (image 1's preprocessed
      crop, rows/cols 80..143), signed ([0,1] -> 2x - 1, Keras' ImageNet scaling).
  VERSIONS              torch / numpy versions.

Exit code 77 when torch is missing.
"""
import json
import os
import struct
import sys

try:
    import numpy as np
    import torch
    import torch.nn.functional as F
except ImportError:
    sys.exit(77)

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", "..", "..", ".."))
WEIGHTS = os.path.join(ROOT, "assets", "mobilenetv2", "mobilenetv2_block10.safetensors")
IMAGES = os.path.join(ROOT, "tests", "reference", "nn", "images_u8.npy")
STRIDE = [1, 2, 1, 2, 1, 1, 2, 1, 1, 1, 1]
DEFAULT_TAPS = ["conv1", "block_1_expand", "block_3_expand", "block_6_expand", "block_10_project"]
TAPS64 = ["conv1", "expanded_conv_depthwise", "expanded_conv_project", "block_1_depthwise",
          "block_2_project", "block_4_expand", "block_5_project", "block_6_depthwise",
          "block_9_project", "block_10_project"]


def read_safetensors(path):
    raw = open(path, "rb").read()
    (n,) = struct.unpack("<Q", raw[:8])
    header = json.loads(raw[8:8 + n])
    data = raw[8 + n:]
    out = {}
    for name, info in header.items():
        if name == "__metadata__":
            continue
        assert info["dtype"] == "F32", name
        b, e = info["data_offsets"]
        out[name] = torch.from_numpy(
            np.frombuffer(data[b:e], dtype="<f4").astype(np.float64).reshape(info["shape"]))
    return out


def prefix(b):
    return "expanded_conv" if b == 0 else f"block_{b}"


def relu6(x):
    return torch.clamp(x, 0.0, 6.0)


def features(W, x, taps):
    """x (1,3,S,S) float64 -> {tap name: (C, H*W)} for the names in taps."""
    got = {}

    def keep(name, t):
        if name in taps:
            got[name] = t[0].reshape(t.shape[1], -1)

    h = relu6(F.conv2d(F.pad(x, (0, 1, 0, 1)), W["Conv1.weight"], W["Conv1.bias"], stride=2))
    keep("conv1", h)
    for b in range(11):
        p = prefix(b)
        inp = h
        if f"{p}_expand.weight" in W:
            w = W[f"{p}_expand.weight"]
            h = relu6(F.conv2d(h, w[:, :, None, None], W[f"{p}_expand.bias"]))
            keep(f"block_{b}_expand", h)
        w = W[f"{p}_depthwise.weight"][:, None]
        if STRIDE[b] == 1:
            h = F.conv2d(h, w, W[f"{p}_depthwise.bias"], padding=1, groups=w.shape[0])
        else:
            h = F.conv2d(F.pad(h, (0, 1, 0, 1)), w, W[f"{p}_depthwise.bias"], stride=2,
                         groups=w.shape[0])
        h = relu6(h)
        keep(f"block_{b}_depthwise", h)
        keep(f"{p}_depthwise", h)
        w = W[f"{p}_project.weight"]
        h = F.conv2d(h, w[:, :, None, None], W[f"{p}_project.bias"])
        if STRIDE[b] == 1 and inp.shape[1] == h.shape[1]:
            h = h + inp
        keep(f"block_{b}_project", h)
        keep(f"{p}_project", h)
    return got


def gram_upper(f):
    g = (f @ f.T) / f.shape[1]
    iu = np.triu_indices(g.shape[0])
    return g.numpy()[iu]


def descriptor(W, x, taps):
    f = features(W, x, set(taps))
    return np.concatenate([gram_upper(f[t]) for t in taps])


def srgb_encode(v):
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1 / 2.4) - 0.055)


def preprocess(lin):
    """(256,256,3) linear float64 -> (1,3,224,224) in [0,1]."""
    v = srgb_encode(np.clip(lin, 0.0, 1.0))[16:240, 16:240]
    return torch.from_numpy(np.ascontiguousarray(v.transpose(2, 0, 1)))[None]


def main():
    torch.set_num_threads(2)
    W = read_safetensors(WEIGHTS)
    imgs = np.load(IMAGES).astype(np.float64) / 255.0
    inputs = [preprocess(imgs[0]), preprocess(imgs[1] * 1.5 - 0.25)]
    rows = []
    for x in inputs:
        half = F.avg_pool2d(x, 2)
        rows.append(np.concatenate([descriptor(W, x, DEFAULT_TAPS),
                                    descriptor(W, half, DEFAULT_TAPS)]))
    np.save(os.path.join(HERE, "expected_default.npy"), np.stack(rows).astype(np.float32))
    x64 = 2.0 * inputs[1][:, :, 80:144, 80:144] - 1.0
    np.save(os.path.join(HERE, "expected_taps64.npy"),
            descriptor(W, x64, TAPS64)[None].astype(np.float32))
    with open(os.path.join(HERE, "VERSIONS"), "w") as f:
        f.write(f"torch {torch.__version__}\nnumpy {np.__version__}\n")
    print("expected_default.npy", np.stack(rows).shape, "expected_taps64.npy",
          descriptor(W, x64, TAPS64).shape)


if __name__ == "__main__":
    main()
