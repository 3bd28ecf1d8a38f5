#!/usr/bin/python3
"""A linear baseline for the predictor's value parameters (issue 15): ridge regression on
the same reduced descriptor, and optionally the same MLP in PyTorch, whitened or not.

Reads two directories written by `imsynth dataset export DS --npy DIR` (training and
validation rows), reduces the descriptors as fit-predictor does (signed log with s = mean
|x|, standardise, a 256-component PCA fitted on the training rows) and reports the median
R^2 over the active value parameters with fit-predictor's definition (only rows where the
parameter is active; SST about the training mean; a hue as the mean R^2 of its cosine and
sine), for PCA scores scaled by (component sd)^gamma: gamma 0 is fit-predictor's whitened
input, gamma 1 the plain PCA scores. Beside them the baselines: the nearest training row by
whitened-PCA distance (retrieval, as the catalogue does it), a random training row, the mean.

    imsynth dataset export train.sqlite --npy tr; imsynth dataset export val.sqlite --npy va
    /usr/bin/python3 scripts/linear-baseline.py tr va [--max-id 3488] [--mlp]
    /usr/bin/python3 scripts/linear-baseline.py all --val-fraction 0.05   # fit-predictor's split

Needs Debian's python3-sklearn (and python3-torch for --mlp): sh scripts/setup-oracles.
"""
import argparse, json, os
import numpy as np
from sklearn.decomposition import PCA
from sklearn.linear_model import Ridge

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def mix64(z):
    """nn_mix64 (nn/batch.c)."""
    m = (1 << 64) - 1
    z = ((z ^ (z >> 30)) * 0xbf58476d1ce4e5b9) & m
    z = ((z ^ (z >> 27)) * 0x94d049bb133111eb) & m
    return z ^ (z >> 31)


def is_validation_id(i, fraction):
    """fit-predictor's held-out ids (predictor_fit.c, is_validation_id)."""
    return (mix64(int(i) ^ 0x76616c6964617465) >> 11) * 2.0 ** -53 < fraction


def load(d, max_id, val_fraction=None, want_val=False):
    ids = np.load(os.path.join(d, 'ids.npy')).ravel()
    keep = ids < max_id if max_id else np.ones(len(ids), bool)
    if val_fraction is not None:
        keep &= np.array([is_validation_id(i, val_fraction) == want_val for i in ids])
    X = np.load(os.path.join(d, 'descriptors.npy'))[keep].astype(np.float32)
    Y = np.load(os.path.join(d, 'params.npy'))[keep]
    A = np.load(os.path.join(d, 'active.npy'))[keep].astype(bool)
    return X, Y, A


def median_r2(pred, Yt, At, Yv, Av, roles, vals):
    """pred(i, rows_train, targets_train) -> predictions on the active validation rows."""
    r2 = []
    for i in vals:
        t, v = At[:, i], Av[:, i]
        if roles[i] == 'hue':
            circ = lambda y: np.stack([np.cos(2 * np.pi * y), np.sin(2 * np.pi * y)], 1)
            zt, zv = circ(Yt[t, i]), circ(Yv[v, i])
        else:
            zt, zv = Yt[t, i][:, None], Yv[v, i][:, None]
        p = pred(i, t, zt).reshape(zv.shape)
        r2.append(np.mean([1 - ((p[:, j] - zv[:, j]) ** 2).sum() /
                           ((zv[:, j] - zt[:, j].mean()) ** 2).sum() for j in range(zv.shape[1])]))
    return float(np.median(r2))


def squash(o, roles, vals):
    """Network outputs -> value columns (sigmoid for a value, tanh for a hue's cos / sin)."""
    import torch
    cols, j = [], 0
    for i in vals:
        if roles[i] == 'hue':
            cols += [torch.tanh(o[:, j]), torch.tanh(o[:, j + 1])]
            j += 2
        else:
            cols.append(torch.sigmoid(o[:, j]))
            j += 1
    return torch.stack(cols, 1)


def mlp(n_in, n_out):
    """fit-predictor's network: 1024-1024, LayerNorm, ReLU, dropout 0.5."""
    import torch
    return torch.nn.Sequential(
        torch.nn.Linear(n_in, 1024), torch.nn.LayerNorm(1024), torch.nn.ReLU(),
        torch.nn.Dropout(0.5), torch.nn.Linear(1024, 1024), torch.nn.LayerNorm(1024),
        torch.nn.ReLU(), torch.nn.Dropout(0.5), torch.nn.Linear(1024, n_out))


def train(net, loss_of, n, epochs, val_loss, seed=None):
    """fit-predictor's schedule: AdamW 1e-3 / 1e-4, cosine, batch 128, loss_of(batch
    indexes) on n rows; leaves net (in eval mode) at the epoch of least val_loss() and
    returns that loss. seed: torch's generator reseeded first (None: as the caller left it)."""
    import torch
    if seed is not None:
        torch.manual_seed(seed)
    opt = torch.optim.AdamW(net.parameters(), 1e-3, weight_decay=1e-4)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, epochs * -(-n // 128))
    best, state = np.inf, None
    for _ in range(epochs):
        net.train()
        perm = torch.randperm(n)
        for b in range(0, n, 128):
            l = loss_of(perm[b:b + 128])
            opt.zero_grad()
            l.backward()
            opt.step()
            sched.step()
        net.eval()
        with torch.no_grad():
            lv = val_loss()
        if lv < best:
            best, state = lv, {k: v.clone() for k, v in net.state_dict().items()}
    net.load_state_dict(state)
    net.eval()
    return best


def mlp_r2(Ft, Fv, Yt, At, Yv, Av, roles, names, vals, epochs=30):
    """fit-predictor's network and loss in PyTorch (1024-1024, LayerNorm, ReLU, dropout 0.5,
    AdamW 1e-3 / 1e-4, cosine schedule, batch 128, value weight 10); the median R^2 at the
    epoch of least validation loss."""
    import torch
    torch.manual_seed(1)
    torch.set_num_threads(1)
    sels = [i for i, r in enumerate(roles) if r == 'selector']
    nch = [int(names[i].split()[1]) for i in sels]
    width = sum(2 if roles[i] == 'hue' else 1 for i in vals)
    net = mlp(Ft.shape[1], sum(nch) + width)

    def targets(Y, A):
        Y, A = torch.tensor(Y), torch.tensor(A.astype(np.float32))
        cls = [torch.clamp((Y[:, i] * n).long(), 0, n - 1) for i, n in zip(sels, nch)]
        tv, mv = [], []
        for i in vals:
            if roles[i] == 'hue':
                tv += [torch.cos(2 * np.pi * Y[:, i]), torch.sin(2 * np.pi * Y[:, i])]
                mv += [A[:, i], A[:, i]]
            else:
                tv.append(Y[:, i])
                mv.append(A[:, i])
        return cls, [A[:, i] for i in sels], torch.stack(tv, 1), torch.stack(mv, 1)

    def loss(X, T, idx):
        cls, am = [c[idx] for c in T[0]], [a[idx] for a in T[1]]
        tv, mv = T[2][idx], T[3][idx]
        o = net(X)
        k, ce = 0, 0
        for c, a, n in zip(cls, am, nch):
            l = torch.nn.functional.cross_entropy(o[:, k:k + n], c, reduction='none')
            ce = ce + (l * a).sum() / a.sum().clamp(min=1)
            k += n
        pv = squash(o[:, k:], roles, vals)
        return ce / len(nch) + 10 * ((pv - tv) ** 2 * mv).sum() / mv.sum().clamp(min=1), pv

    Xt, Xv = torch.tensor(Ft, dtype=torch.float32), torch.tensor(Fv, dtype=torch.float32)
    Tt, Tv = targets(Yt, At), targets(Yv, Av)
    train(net, lambda idx: loss(Xt[idx], Tt, idx)[0], len(Xt), epochs,
          lambda: loss(Xv, Tv, torch.arange(len(Xv)))[0].item())
    with torch.no_grad():
        pv = loss(Xv, Tv, torch.arange(len(Xv)))[1].numpy()
    cols, j = {}, 0
    for i in vals:
        w = 2 if roles[i] == 'hue' else 1
        cols[i] = pv[:, j:j + w]
        j += w
    return median_r2(lambda i, t, z: cols[i][Av[:, i]], Yt, At, Yv, Av, roles, vals)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('train')
    ap.add_argument('val', nargs='?', help='validation rows (default: --val-fraction of train)')
    ap.add_argument('--val-fraction', type=float, default=0.05,
                    help="without VAL: hold out fit-predictor's ids (a hash of the id)")
    ap.add_argument('--max-id', type=int, default=0, help='training rows with id < N only')
    ap.add_argument('--model', default=os.path.join(ROOT, 'assets/model'),
                    help='for the parameter names and roles')
    ap.add_argument('--mlp', action='store_true', help='also the MLP (PyTorch)')
    a = ap.parse_args()
    m = json.load(open(os.path.join(a.model, 'model.json')))
    names, roles = m['parameters'], m['roles']
    vals = [i for i, r in enumerate(roles) if r in ('value', 'hue')]
    if a.val:
        Xt, Yt, At = load(a.train, a.max_id)
        Xv, Yv, Av = load(a.val, 0)
    else:
        Xt, Yt, At = load(a.train, a.max_id, a.val_fraction, False)
        Xv, Yv, Av = load(a.train, 0, a.val_fraction, True)
    s = np.abs(Xt).mean(0) + 1e-12
    Tt, Tv = np.sign(Xt) * np.log1p(np.abs(Xt) / s), np.sign(Xv) * np.log1p(np.abs(Xv) / s)
    mu, sd = Tt.mean(0), Tt.std(0) + 1e-12
    Tt, Tv = (Tt - mu) / sd, (Tv - mu) / sd
    pca = PCA(256, svd_solver='randomized', whiten=True, random_state=0).fit(Tt)
    Pt, Pv = pca.transform(Tt), pca.transform(Tv)
    csd = np.sqrt(pca.explained_variance_)
    print('%d training rows, %d validation rows, %d features, 256 components' %
          (len(Xt), len(Xv), Xt.shape[1]))
    print('| input | model | median value R^2 |')
    print('|---|---|---:|')

    def copied(rows):  # each validation row gets the parameters of training row rows[k]
        def pred(i, t, z):
            y = Yt[rows[Av[:, i]], i]
            return (np.stack([np.cos(2 * np.pi * y), np.sin(2 * np.pi * y)], 1)
                    if roles[i] == 'hue' else y)
        return median_r2(pred, Yt, At, Yv, Av, roles, vals)
    # |a - b|^2 = |a|^2 - 2 a.b + |b|^2, nearest in the whitened PCA (the catalogue's space)
    d2 = (Pv ** 2).sum(1)[:, None] - 2 * Pv @ Pt.T + (Pt ** 2).sum(1)[None, :]
    print('| whitened PCA | nearest training row (retrieval) | %.3f |' % copied(d2.argmin(1)))
    rng = np.random.default_rng(1)
    print('| - | a random training row | %.3f |' % copied(rng.integers(0, len(Pt), len(Pv))))
    print('| - | the training mean | 0 (by definition) |', flush=True)
    for gamma in (0.0, 1.0):
        w = (csd / csd[0]) ** gamma
        Ft, Fv = Pt * w, Pv * w
        # alpha chosen on the last tenth of the training rows, then refitted on them all
        n = len(Ft) * 9 // 10
        alpha = max((median_r2(lambda i, t, z: Ridge(al).fit(Ft[:n][t], z).predict(
            Ft[n:][At[n:, i]]), Yt[:n], At[:n], Yt[n:], At[n:], roles, vals), al)
                    for al in (0.3, 3, 30, 300, 3000))[1]
        r2 = median_r2(lambda i, t, z: Ridge(alpha).fit(Ft[t], z).predict(Fv[Av[:, i]]),
                       Yt, At, Yv, Av, roles, vals)
        label = 'whitened PCA' if gamma == 0 else 'PCA scores'
        print('| %s | ridge (alpha %g, chosen on a tenth of the training rows) | %.3f |' % (
            label, alpha, r2), flush=True)
        if a.mlp:
            w = w / np.sqrt(np.mean(w * w))  # unit mean variance, as whitened
            print('| %s | MLP (fit-predictor settings, PyTorch) | %.3f |' % (
                label, mlp_r2(Pt * w, Pv * w, Yt, At, Yv, Av, roles, names, vals)), flush=True)


if __name__ == '__main__':
    main()
