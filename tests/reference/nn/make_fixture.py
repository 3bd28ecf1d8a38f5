#!/usr/bin/python3
"""PyTorch oracle for nn's VGG19 Gram descriptor.

    /usr/bin/python3 tests/reference/nn/make_fixture.py            # the committed fixture
    /usr/bin/python3 tests/reference/nn/make_fixture.py --full DIR  # full VGG19, for
                                                                    # tests/unit/test_nn_torch.c

Made with torch 1.13 / torchvision 0.14 (Debian bookworm). Both modes build torchvision's
VGG19 `features` (torchvision.models.vgg.make_layers with config "E"), replace every
MaxPool2d by the pooling under test and make the ReLUs out-of-place, fill it with seeded
random weights (non-zero biases, so bias handling is checked), write them as safetensors
by hand (torch 1.13 has no safetensors module), and write Gram descriptors of two
images computed by torch: G = F F^T / (H W) after conv1_2, conv2_2, conv3_4, conv4_4 and
conv5_4, upper triangle with diagonal row by row, concatenated.

Committed fixture (default mode, < 1.5 MB): a reduced VGG19 (every width divided by 8,
same 16 convs, pools and taps) whose tensors cycle through F32, F16 and BF16, so all three
dtypes are read; the weights the network computes with are the rounded ones. Inputs are
two 256x256 RGB uint8 images; image 0 is used as u8/255, image 1 as u8/255*1.5-0.25
(values outside [0,1], so the clamp is exercised). Preprocessing is the descriptor's:
clamp to [0,1], centre crop rows/cols 16..239, ImageNet mean/std.

Exit code 77 when torch is missing (the test then skips).
"""
import json
import os
import struct
import sys

try:
    import numpy as np
    import torch
    import torchvision
    from torchvision.models.vgg import cfgs, make_layers
except ImportError:
    sys.exit(77)

HERE = os.path.dirname(os.path.abspath(__file__))
GRAM_AFTER = [2, 7, 16, 25, 34]  # features indices of conv1_2 ... conv5_4
MEAN = [0.485, 0.456, 0.406]
STD = [0.229, 0.224, 0.225]

DTYPE_NAME = {torch.float32: "F32", torch.float16: "F16", torch.bfloat16: "BF16"}


def write_safetensors(path, tensors):
    """tensors: list of (name, tensor) in the dtype to store."""
    header, blobs, offset = {}, [], 0
    for name, t in tensors:
        t = t.contiguous()
        if t.dtype == torch.bfloat16:  # numpy has no bfloat16: take the raw 16 bits
            raw = t.view(torch.int16).numpy().astype("<i2").tobytes()
        else:
            raw = t.numpy().astype(t.numpy().dtype.newbyteorder("<")).tobytes()
        header[name] = {"dtype": DTYPE_NAME[t.dtype], "shape": list(t.shape),
                        "data_offsets": [offset, offset + len(raw)]}
        blobs.append(raw)
        offset += len(raw)
    header["__metadata__"] = {"format": "pt", "made_by": "tests/reference/nn/make_fixture.py"}
    h = json.dumps(header, separators=(",", ":")).encode()
    h += b" " * (-len(h) % 8)
    with open(path + ".tmp", "wb") as f:
        f.write(struct.pack("<Q", len(h)))
        f.write(h)
        for b in blobs:
            f.write(b)
    os.replace(path + ".tmp", path)


def build(widths, pool):
    cfg = []
    for b, n in enumerate([2, 2, 4, 4, 4]):
        cfg += [widths[b]] * n + ["M"]
    feats = make_layers(cfg, batch_norm=False)
    for i, m in enumerate(feats):
        if isinstance(m, torch.nn.MaxPool2d):
            feats[i] = {"avg3": torch.nn.AvgPool2d(3), "avg2": torch.nn.AvgPool2d(2),
                        "max2": torch.nn.MaxPool2d(2)}[pool]
        elif isinstance(m, torch.nn.ReLU):
            feats[i] = torch.nn.ReLU(inplace=False)
    return feats.eval()


def random_weights(feats, seed, dtypes):
    """Seeded He-normal weights and N(0, 0.05) biases, rounded through the storage dtype
    of each tensor (cycling through dtypes). Returns [(name, stored tensor)]."""
    g = torch.Generator().manual_seed(seed)
    stored, k = [], 0
    for i, m in enumerate(feats):
        if not isinstance(m, torch.nn.Conv2d):
            continue
        fan_in = m.in_channels * 9
        w = torch.randn(m.weight.shape, generator=g) * (2.0 / fan_in) ** 0.5
        b = torch.randn(m.bias.shape, generator=g) * 0.05
        for name, t, param in (("weight", w, m.weight), ("bias", b, m.bias)):
            dt = dtypes[k % len(dtypes)]
            k += 1
            ts = t.to(dt)
            with torch.no_grad():
                param.copy_(ts.float())
            stored.append((f"features.{i}.{name}", ts))
    return stored


def preprocess(img):
    """img (H, W, 3) float32 linear -> (3, 224, 224) normalised."""
    x = torch.from_numpy(img).clamp(0.0, 1.0)
    h, w = x.shape[0], x.shape[1]
    y0, x0 = (h - 224) // 2, (w - 224) // 2
    x = x[y0:y0 + 224, x0:x0 + 224].permute(2, 0, 1)
    mean = torch.tensor(MEAN, dtype=torch.float32).view(3, 1, 1)
    std = torch.tensor(STD, dtype=torch.float32).view(3, 1, 1)
    return (x - mean) / std


def descriptors(feats, batch, post_relu):
    rows = [[] for _ in range(batch.shape[0])]
    x = batch
    with torch.no_grad():
        for i, m in enumerate(feats):
            x = m(x)
            # x is now the output of features[i]; post-ReLU taps read features[i+1]'s output
            tap = (i - 1 if post_relu else i) in GRAM_AFTER and (
                isinstance(m, torch.nn.ReLU) if post_relu else isinstance(m, torch.nn.Conv2d))
            if tap:
                n, c, h, w = x.shape
                f = x.reshape(n, c, h * w)
                g = torch.bmm(f, f.transpose(1, 2)) / (h * w)
                iu = torch.triu_indices(c, c)
                for k in range(n):
                    rows[k].append(g[k][iu[0], iu[1]])
            if i >= GRAM_AFTER[-1] + 1:
                break
    return torch.stack([torch.cat(r) for r in rows]).numpy().astype(np.float32)


def test_images(rng):
    """Two 256x256 RGB uint8 textures: oriented waves plus noise, different per image."""
    yy, xx = np.mgrid[0:256, 0:256].astype(np.float64)
    imgs = []
    for k in range(2):
        chans = []
        for c in range(3):
            f1, f2, a = rng.uniform(0.02, 0.3), rng.uniform(0.02, 0.3), rng.uniform(0, np.pi)
            v = 0.5 + 0.25 * np.sin(f1 * (xx * np.cos(a) + yy * np.sin(a)))
            v += 0.15 * np.sin(f2 * xx + 0.7 * k) * np.cos(f2 * yy)
            v += 0.1 * rng.standard_normal(v.shape)
            chans.append(v)
        imgs.append(np.clip(np.stack(chans, -1) * 255.0 + 0.5, 0, 255).astype(np.uint8))
    return np.stack(imgs)


def linear_images(u8):
    a = u8[0].astype(np.float32) / np.float32(255.0)
    b = u8[1].astype(np.float32) / np.float32(255.0) * np.float32(1.5) - np.float32(0.25)
    return [a, b]


CONFIGS = [("avg3", False), ("avg2", False), ("max2", True)]


def main():
    torch.set_num_threads(max(1, int(os.environ.get("OMP_NUM_THREADS", "2"))))
    full = len(sys.argv) == 3 and sys.argv[1] == "--full"
    if full:
        out = sys.argv[2]
        widths = [64, 128, 256, 512, 512]
        dtypes = [torch.float32]
        configs = [("avg3", False), ("max2", True)]
    else:
        out = HERE
        widths = [8, 16, 32, 64, 64]
        dtypes = [torch.float32, torch.float16, torch.bfloat16]
        configs = CONFIGS
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(20261122)
    u8 = test_images(rng)
    batch = torch.stack([preprocess(x) for x in linear_images(u8)])
    stored = None
    for pool, post in configs:
        feats = build(widths, pool)
        s = random_weights(feats, 5, dtypes)  # same seed: same weights for every pooling
        stored = stored or s
        d = descriptors(feats, batch, post)
        np.save(os.path.join(out, f"expected_{pool}_{'post' if post else 'pre'}.npy"), d)
    write_safetensors(os.path.join(out, "weights.safetensors"), stored)
    np.save(os.path.join(out, "images_u8.npy"), u8)
    with open(os.path.join(out, "VERSIONS"), "w") as f:
        f.write(f"torch {torch.__version__}\ntorchvision {torchvision.__version__}\n"
                f"numpy {np.__version__}\n")


if __name__ == "__main__":
    main()
