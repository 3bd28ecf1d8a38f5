#!/usr/bin/python3
"""Convert a torchvision VGG19 checkpoint to the safetensors file `imsynth describe
--weights` reads.

    /usr/bin/python3 scripts/convert_vgg19.py vgg19-dcbb9e9d.pth vgg19.safetensors [--dtype f32|f16|bf16]

The input is what torchvision's VGG19_Weights.IMAGENET1K_V1 downloads (a state dict), or
any state dict / full model with the same keys. Only the convolutional part is kept:
features.{0,2,5,7,10,12,14,16,19,21,23,25,28,30,32,34}.{weight,bias}, under torchvision's
names. F32 keeps the weights exact; F16/BF16 halve the file (the descriptor then changes
by the rounding of the weights). Needs torch (Debian: python3-torch); torch 1.13 has no
safetensors module, so the format (8-byte little-endian header length, JSON header,
raw little-endian data) is written here.
"""
import argparse
import json
import os
import struct
import sys

CONV_INDICES = [0, 2, 5, 7, 10, 12, 14, 16, 19, 21, 23, 25, 28, 30, 32, 34]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("checkpoint")
    ap.add_argument("output")
    ap.add_argument("--dtype", choices=["f32", "f16", "bf16"], default="f32")
    args = ap.parse_args()
    try:
        import torch
    except ImportError:
        sys.exit("convert_vgg19.py: needs torch (run with /usr/bin/python3 or install python3-torch)")

    obj = torch.load(args.checkpoint, map_location="cpu")
    if hasattr(obj, "state_dict"):
        obj = obj.state_dict()
    if isinstance(obj, dict) and "state_dict" in obj and isinstance(obj["state_dict"], dict):
        obj = obj["state_dict"]
    dtype = {"f32": torch.float32, "f16": torch.float16, "bf16": torch.bfloat16}[args.dtype]
    name = {"f32": "F32", "f16": "F16", "bf16": "BF16"}[args.dtype]

    header, blobs, offset = {}, [], 0
    cin = 3
    for i in CONV_INDICES:
        for part in ("weight", "bias"):
            key = f"features.{i}.{part}"
            # Checkpoints saved from DataParallel prefix keys with "module.".
            t = obj.get(key, obj.get("module." + key))
            if t is None:
                sys.exit(f"convert_vgg19.py: {args.checkpoint}: no tensor {key} "
                         "(is this a torchvision VGG19 checkpoint?)")
            t = t.detach().to(dtype).contiguous()
            if part == "weight":
                if t.dim() != 4 or tuple(t.shape[1:]) != (cin, 3, 3):
                    sys.exit(f"convert_vgg19.py: {args.checkpoint}: {key} has shape "
                             f"{tuple(t.shape)}, expected (cout, {cin}, 3, 3)")
                cin = t.shape[0]
            raw = (t.view(torch.int16) if dtype != torch.float32 else t).numpy()
            raw = raw.astype(raw.dtype.newbyteorder("<")).tobytes()
            header[key] = {"dtype": name, "shape": list(t.shape),
                           "data_offsets": [offset, offset + len(raw)]}
            blobs.append(raw)
            offset += len(raw)
    header["__metadata__"] = {"source": os.path.basename(args.checkpoint),
                              "converted_by": "scripts/convert_vgg19.py"}
    h = json.dumps(header, separators=(",", ":")).encode()
    h += b" " * (-len(h) % 8)
    tmp = args.output + ".tmp"
    with open(tmp, "wb") as f:
        f.write(struct.pack("<Q", len(h)))
        f.write(h)
        for b in blobs:
            f.write(b)
    os.replace(tmp, args.output)
    print(f"{args.output}: {len(CONV_INDICES)} convs, {offset / 1e6:.1f} MB of {name} weights")


if __name__ == "__main__":
    main()
