#!/usr/bin/python3
"""Reference training runs in PyTorch for tests/unit/test_nn_train_torch.c.

Run with the system Python that has torch 1.13 (``/usr/bin/python3 make_fixtures.py``);
it rewrites the fixtures in this directory. For each case it builds the torch module the
C model mirrors (same state_dict names), initialises it with torch's own initialisers
(torch.manual_seed), writes the initial weights, trains it on fixed batches (rows
[k*B, (k+1)*B) of the data, cycling: the C side's --no-shuffle order) and writes

    <case>/init.safetensors     weights before the first step
    <case>/final.safetensors    weights and optimiser state after the last step
                                (optimizer.exp_avg.<name>, optimizer.exp_avg_sq.<name>,
                                optimizer.momentum_buffer.<name>; metadata optimizer.step)
    <case>/losses.npy           the loss of every step (float32)
    <case>/spec.txt             arch, heads, loss and optimiser the C test reads

Shared by the cases: x.npy (64 x 16), y.npy (64 x 8), mask.npy (64 x 8), colw.npy (1 x 8,
per-column loss weights, used where spec.txt says colw).

safetensors is written and read by hand (the package is not installed here): an 8-byte
little-endian header length, a JSON header, raw little-endian float32 data.

``make_fixtures.py --check MODEL.safetensors X.npy PRED.npy`` loads a checkpoint written by
imsynth into the torch module its metadata describes and checks that torch's predictions
equal imsynth's (PRED.npy, from ``imsynth infer``): the C -> torch direction of the names.
"""
import json
import math
import os
import struct
import sys

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F

HERE = os.path.dirname(os.path.abspath(__file__))
N, IN, YCOLS, BATCH, STEPS = 64, 16, 8, 16, 100
COLUMN_WEIGHTS = np.array([[1, 2, 0.5, 1, 1.5, 1, 0.75, 1.25]], np.float32)


# ---------------------------------------------------------------- safetensors by hand

def save_safetensors(path, tensors, metadata=None):
    header, offset, blobs = {}, 0, []
    if metadata:
        header["__metadata__"] = {k: str(v) for k, v in metadata.items()}
    for name, t in tensors.items():
        a = np.ascontiguousarray(t.detach().cpu().numpy().astype("<f4"))
        header[name] = {"dtype": "F32", "shape": list(a.shape),
                        "data_offsets": [offset, offset + a.nbytes]}
        offset += a.nbytes
        blobs.append(a.tobytes())
    h = json.dumps(header, separators=(",", ":")).encode()
    h += b" " * (-len(h) % 8)
    with open(path, "wb") as f:
        f.write(struct.pack("<Q", len(h)))
        f.write(h)
        for b in blobs:
            f.write(b)


def load_safetensors(path):
    with open(path, "rb") as f:
        raw = f.read()
    (n,) = struct.unpack("<Q", raw[:8])
    header = json.loads(raw[8:8 + n])
    meta = header.pop("__metadata__", {})
    data = raw[8 + n:]
    out = {}
    for name, info in header.items():
        assert info["dtype"] == "F32", name
        b, e = info["data_offsets"]
        out[name] = torch.from_numpy(
            np.frombuffer(data[b:e], dtype="<f4").reshape(info["shape"]).copy())
    return out, meta


# ---------------------------------------------------------------- the modules

class Block(nn.Module):
    """A residual hidden layer: linear, [norm], activation, [dropout]; adds its input if the
    widths agree."""

    def __init__(self, i, o, act, ln, p):
        super().__init__()
        self.linear = nn.Linear(i, o)
        if ln:
            self.norm = nn.LayerNorm(o)
        self.act = act
        self.drop = nn.Dropout(p) if p > 0 else nn.Identity()
        self.skip = i == o

    def forward(self, x):
        h = self.linear(x)
        if hasattr(self, "norm"):
            h = self.norm(h)
        h = self.drop(self.act(h))
        return x + h if self.skip else h


def parse_arch(spec):
    body = spec[len("mlp:"):].split(",")
    widths = [int(w) for w in body[0].split("-")]
    opts = dict(act="relu", slope=0.01, ln=False, res=False, dropout=0.0)
    for o in body[1:]:
        if o in ("relu", "gelu"):
            opts["act"] = o
        elif o.startswith("leaky"):
            opts["act"] = "leaky"
            if "=" in o:
                opts["slope"] = float(o.split("=")[1])
        elif o == "ln":
            opts["ln"] = True
        elif o == "res":
            opts["res"] = True
        elif o.startswith("dropout="):
            opts["dropout"] = float(o.split("=")[1])
        elif o.startswith("init="):
            pass
        else:
            raise ValueError(o)
    return widths, opts


def make_act(opts):
    return {"relu": nn.ReLU(), "gelu": nn.GELU(),
            "leaky": nn.LeakyReLU(opts["slope"])}[opts["act"]]


class MLP(nn.Module):
    def __init__(self, spec):
        super().__init__()
        widths, opts = parse_arch(spec)
        mods = []
        for l in range(len(widths) - 1):
            i, o = widths[l], widths[l + 1]
            last = l == len(widths) - 2
            if opts["res"] and not last:
                mods.append(Block(i, o, make_act(opts), opts["ln"], opts["dropout"]))
                continue
            mods.append(nn.Linear(i, o))
            if last:
                break
            if opts["ln"]:
                mods.append(nn.LayerNorm(o))
            mods.append(make_act(opts))
            if opts["dropout"] > 0:
                mods.append(nn.Dropout(opts["dropout"]))
        self.trunk = nn.Sequential(*mods)

    def forward(self, x):
        return self.trunk(x)


def parse_heads(spec, ycols):
    """[(kind, y_first, count, classes, unit, out_first, weight)] as nn_heads_parse."""
    heads, out = [], 0
    if not spec:
        return [("linear", 0, ycols, 0, False, 0, 1.0)]
    for h in spec.split(","):
        w = 1.0
        if "@" in h:
            h, w = h.split("@")
            w = float(w)
        kind, rest = h.split(":", 1)
        if kind == "softmax":
            unit = rest.endswith(":unit")
            rest = rest.split(":")[0]
            c, k = (int(v) for v in rest.split("/"))
            heads.append((kind, c, 1, k, unit, out, w))
            out += k
        else:
            a, _, b = rest.partition("-")
            a, b = int(a), int(b or a)
            heads.append((kind, a, b - a + 1, 0, False, out, w))
            out += b - a + 1
    return heads


def head_loss(z, y, m, heads, loss, colw=None):
    """The C model's loss: per head sum(m c e) / max(1, sum m) (c: per-column weights),
    weighted and summed."""
    total = 0.0
    if colw is None:
        colw = torch.ones(y.shape[1])
    for kind, yf, cnt, k, unit, of, w in heads:
        mm = m[:, yf:yf + cnt] if m is not None else torch.ones(z.shape[0], cnt)
        denom = mm.sum().clamp(min=1.0)
        if kind == "softmax":
            v = y[:, yf]
            cls = torch.round(v * (k - 1)) if unit else v
            cls = torch.where(mm[:, 0] != 0, cls, torch.zeros_like(cls)).long()
            ce = F.cross_entropy(z[:, of:of + k], cls, reduction="none")
            total = total + w * colw[yf] * (ce * mm[:, 0]).sum() / denom
            continue
        p = z[:, of:of + cnt]
        if kind == "sigmoid":
            p = torch.sigmoid(p)
        t = y[:, yf:yf + cnt]
        t = torch.where(mm != 0, t, p.detach())  # masked targets may be anything
        if loss == "mse":
            e = (p - t) ** 2
        elif loss == "l1":
            e = (p - t).abs()
        else:
            e = (p - t) ** 2 + 20.0 * (torch.log(p + 1e-7) - torch.log(t + 1e-7)) ** 2
        total = total + w * (e * mm * colw[yf:yf + cnt]).sum() / denom
    return total


# ---------------------------------------------------------------- the cases

CASES = {
    # the case: a 3-layer ReLU MLP, one regression head, MSE, AdamW
    "adamw_mlp3": dict(arch="mlp:16-64-64-4,relu", heads="linear:0-3", loss="mse",
                       mask=False, opt="adamw", lr=1e-3, wd=1e-2),
    # the predictor's shape: masked sigmoid regression (thesis loss) + two softmax heads,
    # per-column loss weights (colw.npy)
    "adamw_mixed": dict(arch="mlp:16-48-48-13,gelu,ln", heads="sigmoid:0-5,softmax:6/4,softmax:7/3:unit@0.5",
                        loss="thesis", mask=True, colw=True, opt="adamw", lr=2e-3, wd=1e-2),
    # SGD with momentum and L2 decay, clipped gradients, a step schedule, leaky ReLU
    "sgd_clip_step": dict(arch="mlp:16-32-32-4,leaky=0.1", heads="sigmoid:0-3", loss="l1",
                          mask=True, opt="sgd", lr=5e-2, wd=1e-3, momentum=0.9, clip=0.5,
                          schedule="step", step_size=30, gamma=0.5),
    # Adam (L2 decay) on residual LayerNorm blocks, cosine schedule with warm-up
    "adam_res_cosine": dict(arch="mlp:16-32-32-32-4,relu,ln,res", heads="linear:0-3",
                            loss="mse", mask=True, opt="adam", lr=3e-3, wd=1e-4,
                            schedule="cosine", warmup=10),
}


def cosine_lambda(warmup, total):
    def f(t):
        if t < warmup:
            return (t + 1) / warmup
        s = min(max((t - warmup) / (total - warmup), 0.0), 1.0)
        return 0.5 * (1.0 + math.cos(math.pi * s))
    return f


def run_case(name, c, x, y, m):
    torch.manual_seed(1000 + sorted(CASES).index(name))
    model = MLP(c["arch"])
    heads = parse_heads(c["heads"], YCOLS)
    d = os.path.join(HERE, name)
    os.makedirs(d, exist_ok=True)
    save_safetensors(os.path.join(d, "init.safetensors"), model.state_dict())
    if c["opt"] == "adamw":
        opt = torch.optim.AdamW(model.parameters(), lr=c["lr"], weight_decay=c["wd"])
    elif c["opt"] == "adam":
        opt = torch.optim.Adam(model.parameters(), lr=c["lr"], weight_decay=c["wd"])
    else:
        opt = torch.optim.SGD(model.parameters(), lr=c["lr"], momentum=c["momentum"],
                              weight_decay=c["wd"])
    sched = None
    if c.get("schedule") == "step":
        sched = torch.optim.lr_scheduler.StepLR(opt, c["step_size"], c["gamma"])
    elif c.get("schedule") == "cosine":
        sched = torch.optim.lr_scheduler.LambdaLR(opt, cosine_lambda(c["warmup"], STEPS))
    X, Y = torch.from_numpy(x), torch.from_numpy(y)
    M = torch.from_numpy(m) if c["mask"] else None
    colw = torch.from_numpy(COLUMN_WEIGHTS[0]) if c.get("colw") else None
    losses = []
    for step in range(STEPS):
        lo = (step * BATCH) % N
        xb, yb = X[lo:lo + BATCH], Y[lo:lo + BATCH]
        mb = M[lo:lo + BATCH] if M is not None else None
        opt.zero_grad()
        loss = head_loss(model(xb), yb, mb, heads, c["loss"], colw)
        loss.backward()
        if c.get("clip"):
            torch.nn.utils.clip_grad_norm_(model.parameters(), c["clip"])
        opt.step()
        if sched:
            sched.step()
        losses.append(loss.item())
    state = dict(model.state_dict())
    names = {id(p): n for n, p in model.named_parameters()}
    for p, st in opt.state.items():
        for key in ("exp_avg", "exp_avg_sq", "momentum_buffer"):
            if key in st:
                state["optimizer.%s.%s" % (key, names[id(p)])] = st[key]
    save_safetensors(os.path.join(d, "final.safetensors"), state,
                     {"optimizer.step": STEPS})
    np.save(os.path.join(d, "losses.npy"), np.array(losses, dtype=np.float32))
    with open(os.path.join(d, "spec.txt"), "w") as f:
        for k in ("arch", "heads", "loss", "mask", "colw", "opt", "lr", "wd", "momentum", "clip",
                  "schedule", "step_size", "gamma", "warmup"):
            if k in c:
                f.write("%s %s\n" % (k, c[k]))
        f.write("batch %d\nsteps %d\n" % (BATCH, STEPS))
    print("%-16s loss %.6f -> %.6f" % (name, losses[0], losses[-1]))


def make_data():
    rng = np.random.default_rng(13)
    x = rng.standard_normal((N, IN)).astype(np.float32)
    # targets that depend on x, so that training has something to learn
    w = rng.standard_normal((IN, YCOLS)).astype(np.float32) / 4
    lin = x @ w
    y = np.empty((N, YCOLS), np.float32)
    y[:, :6] = 1 / (1 + np.exp(-lin[:, :6]))           # regression targets in (0, 1)
    y[:, 6] = np.clip(np.floor((lin[:, 6] + 1) * 2), 0, 3)  # class 0..3
    y[:, 7] = np.clip(np.round(lin[:, 7] + 1), 0, 2) / 2    # selector 0, 0.5, 1 (3 classes)
    mask = (rng.random((N, YCOLS)) < 0.7).astype(np.float32)
    # masked targets hold junk the model must ignore (NaN would also be allowed)
    y[:, :6] = np.where(mask[:, :6] != 0, y[:, :6], 7.0)
    return x, y, mask


def check(model_path, x_path, pred_path):
    """A checkpoint written by imsynth loads into torch, and predicts as imsynth did."""
    state, meta = load_safetensors(model_path)
    model = MLP(meta["imsynth.arch"])
    weights = {k: v for k, v in state.items() if not k.startswith("optimizer.")}
    model.load_state_dict(weights, strict=True)
    heads = parse_heads(meta["imsynth.heads"], int(meta["imsynth.y_cols"]))
    x = torch.from_numpy(np.load(x_path).astype(np.float32))
    with torch.no_grad():
        z = model(x)
    want = np.zeros((x.shape[0], int(meta["imsynth.y_cols"])), np.float32)
    for kind, yf, cnt, k, unit, of, w in heads:
        if kind == "softmax":
            cls = torch.argmax(z[:, of:of + k], dim=1).float()
            want[:, yf] = (cls / (k - 1) if unit else cls).numpy()
        else:
            p = z[:, of:of + cnt]
            want[:, yf:yf + cnt] = (torch.sigmoid(p) if kind == "sigmoid" else p).numpy()
    got = np.load(pred_path)
    err = np.abs(got - want).max()
    print("%s: %d tensors loaded strictly into torch; max |imsynth - torch| prediction %.3g"
          % (model_path, len(weights), err))
    return 0 if err < 1e-5 else 1


def main():
    if len(sys.argv) == 5 and sys.argv[1] == "--check":
        sys.exit(check(*sys.argv[2:]))
    torch.set_num_threads(1)
    x, y, m = make_data()
    np.save(os.path.join(HERE, "x.npy"), x)
    np.save(os.path.join(HERE, "y.npy"), y)
    np.save(os.path.join(HERE, "mask.npy"), m)
    np.save(os.path.join(HERE, "colw.npy"), COLUMN_WEIGHTS)
    for name in sorted(CASES):
        run_case(name, CASES[name], x, y, m)
    with open(os.path.join(HERE, "VERSIONS"), "w") as f:
        f.write("torch %s\nnumpy %s\n" % (torch.__version__, np.__version__))


if __name__ == "__main__":
    main()
