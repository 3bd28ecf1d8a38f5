#!/usr/bin/python3
"""Value parameters conditioned on the selectors (issue 15): does knowing the multiplexer
combination make the value parameters learnable?

The bundled predictor gives every top-k hypothesis the same value parameters: one sigmoid
head beside the selectors' softmax heads, so a value is predicted as its expectation over
all the combinations the image might be. Session 11 measured that a value parameter moves
the descriptor a different way in almost every sample (the combination decides what it
does). This script trains, on the same rows and reduced input as fit-predictor (whitened
256-component PCA of the signed-log, standardised Grams):

  U  fit-predictor's network in PyTorch (selectors and values; scripts/linear-baseline.py),
  C  a second network of the same shape whose input is the PCA scores and the one-hot
     selector classes, trained on the true classes (masked value loss only); with --noise q
     each training row's selector is replaced by a uniform random class with probability q,
  S  one network of U's shape reading the PCA scores and the one-hot classes, trained on
     every row twice: with the one-hot part zero (selector and value losses: U's task) and
     with the true classes (value loss only); predicting, a pass with zeros gives the
     selectors, a pass per combination its values,

and reports the median R^2 over the active value parameters (fit-predictor's definition) on
the validation rows for U's values and for C's given (a) the true classes (an upper bound:
what the values would be worth if the combination were known), (b) U's likeliest
combination, (c) of U's top-k combinations the one a renderer would most likely pick,
taken here as the one with the most correct active selectors (ties: the likelier), with U's
values on the same rows beside it.

    imsynth dataset export ds.sqlite --npy all
    /usr/bin/python3 scripts/conditional-values.py all [--val VAL] [--noise 0.3] [--top-k 8]

Needs Debian's python3-torch and python3-sklearn (sh scripts/setup-oracles).
"""
import argparse, importlib.util, json, os
import numpy as np
import torch

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
_spec = importlib.util.spec_from_file_location('lb', os.path.join(ROOT, 'scripts/linear-baseline.py'))
lb = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(lb)


def value_columns(Y, roles, vals):
    """Targets in the network's columns: a value as is, a hue as (cos, sin)."""
    cols = []
    for i in vals:
        if roles[i] == 'hue':
            cols += [np.cos(2 * np.pi * Y[:, i]), np.sin(2 * np.pi * Y[:, i])]
        else:
            cols.append(Y[:, i])
    return np.stack(cols, 1).astype(np.float32)


def value_mask(A, roles, vals):
    return np.stack(sum(([A[:, i]] * (2 if roles[i] == 'hue' else 1) for i in vals), []),
                    1).astype(np.float32)


def r2_of(pv, Yt, At, Yv, Av, roles, vals):
    """Median R^2 of value columns pv (validation rows) as fit-predictor reports it."""
    cols, j = {}, 0
    for i in vals:
        w = 2 if roles[i] == 'hue' else 1
        cols[i] = pv[:, j:j + w]
        j += w
    return lb.median_r2(lambda i, t, z: cols[i][Av[:, i]], Yt, At, Yv, Av, roles, vals)


def top_combos(probs, k):
    """The k likeliest combinations of independent heads (a beam, as predictor_predict)."""
    beam = [(0.0, ())]
    for p in probs:
        nxt = [(lp + np.log(max(float(q), 1e-30)), cls + (c,)) for lp, cls in beam
               for c, q in enumerate(p)]
        nxt.sort(key=lambda t: -t[0])
        beam = nxt[:k]
    return [cls for _, cls in beam]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('train')
    ap.add_argument('--val', help='validation rows (default: fit-predictor\'s 5%% of train)')
    ap.add_argument('--max-id', type=int, default=0)
    ap.add_argument('--epochs', type=int, default=30)
    ap.add_argument('--noise', type=float, default=0.0)
    ap.add_argument('--top-k', type=int, default=8)
    ap.add_argument('--model', default=os.path.join(ROOT, 'assets/model'))
    a = ap.parse_args()
    torch.set_num_threads(int(os.environ.get("THREADS", "2")))
    m = json.load(open(os.path.join(a.model, 'model.json')))
    names, roles = m['parameters'], m['roles']
    vals = [i for i, r in enumerate(roles) if r in ('value', 'hue')]
    sels = [i for i, r in enumerate(roles) if r == 'selector']
    nch = [int(names[i].split()[1]) for i in sels]
    if a.val:
        Xt, Yt, At = lb.load(a.train, a.max_id)
        Xv, Yv, Av = lb.load(a.val, 0)
    else:
        Xt, Yt, At = lb.load(a.train, a.max_id, 0.05, False)
        Xv, Yv, Av = lb.load(a.train, 0, 0.05, True)
    s = np.abs(Xt).mean(0) + 1e-12
    Tt, Tv = np.sign(Xt) * np.log1p(np.abs(Xt) / s), np.sign(Xv) * np.log1p(np.abs(Xv) / s)
    mu, sd = Tt.mean(0), Tt.std(0) + 1e-12
    from sklearn.decomposition import PCA
    pca = PCA(256, svd_solver='randomized', whiten=True, random_state=0).fit((Tt - mu) / sd)
    Pt = torch.tensor(pca.transform((Tt - mu) / sd), dtype=torch.float32)
    Pv = torch.tensor(pca.transform((Tv - mu) / sd), dtype=torch.float32)
    del Xt, Xv, Tt, Tv
    print('%d training rows, %d validation rows; %d selectors (%d classes), %d value columns' %
          (len(Pt), len(Pv), len(sels), sum(nch), 2 * len(vals) - sum(r != 'hue' for r in roles
                                                                         if r in ('value', 'hue'))))

    def classes(Y):
        return np.stack([np.clip((Y[:, i] * n).astype(int), 0, n - 1)
                         for i, n in zip(sels, nch)], 1)

    def onehot(C):
        return torch.cat([torch.nn.functional.one_hot(torch.tensor(C[:, s]), n).float()
                          for s, n in enumerate(nch)], 1)

    Ct, Cv = classes(Yt), classes(Yv)
    Vt, Vv = torch.tensor(value_columns(Yt, roles, vals)), torch.tensor(value_columns(Yv, roles, vals))
    Mt, Mv = torch.tensor(value_mask(At, roles, vals)), torch.tensor(value_mask(Av, roles, vals))
    St = torch.tensor(At[:, sels].astype(np.float32))
    Sv = torch.tensor(Av[:, sels].astype(np.float32))
    width = Vt.shape[1]

    # U: fit-predictor's network
    torch.manual_seed(1)  # the initial weights: the run is repeatable
    U = lb.mlp(Pt.shape[1], sum(nch) + width)

    def u_loss(X, C, S, V, M, idx):
        o = U(X[idx])
        ce, k = 0, 0
        for s, n in enumerate(nch):
            l = torch.nn.functional.cross_entropy(o[:, k:k + n], torch.tensor(C[idx, s]),
                                                  reduction='none')
            ce = ce + (l * S[idx, s]).sum() / S[idx, s].sum().clamp(min=1)
            k += n
        pv = lb.squash(o[:, k:], roles, vals)
        return ce / len(nch) + 10 * ((pv - V[idx]) ** 2 * M[idx]).sum() / M[idx].sum().clamp(min=1)

    allv = torch.arange(len(Pv))
    lb.train(U, lambda idx: u_loss(Pt, Ct, St, Vt, Mt, idx), len(Pt), a.epochs,
             lambda: u_loss(Pv, Cv, Sv, Vv, Mv, allv).item(), seed=1)
    with torch.no_grad():
        o = U(Pv)
    probs, k = [], 0
    for n in nch:
        probs.append(torch.softmax(o[:, k:k + n], 1).numpy())
        k += n
    u_vals = lb.squash(o[:, k:], roles, vals).numpy()
    acc = np.mean([(p.argmax(1) == Cv[:, s])[Av[:, sels[s]]].mean() for s, p in enumerate(probs)])

    # C: values given the one-hot combination
    torch.manual_seed(1)  # the initial weights: the run is repeatable
    Cnet = lb.mlp(Pt.shape[1] + sum(nch), width)
    gen = np.random.default_rng(2)

    def c_loss(X, C, V, M, idx, noise):
        c = C[idx].copy()
        if noise > 0:
            flip = gen.random(c.shape) < noise
            c[flip] = (gen.random(c.shape) * np.array(nch)).astype(int)[flip]
        pv = lb.squash(Cnet(torch.cat([X[idx], onehot(c)], 1)), roles, vals)
        return 10 * ((pv - V[idx]) ** 2 * M[idx]).sum() / M[idx].sum().clamp(min=1)

    lb.train(Cnet, lambda idx: c_loss(Pt, Ct, Vt, Mt, idx, a.noise), len(Pt), a.epochs,
             lambda: c_loss(Pv, Cv, Vv, Mv, allv.numpy(), 0).item(), seed=1)

    def c_vals(C):
        with torch.no_grad():
            return lb.squash(Cnet(torch.cat([Pv, onehot(C)], 1)), roles, vals).numpy()

    # S: one network, each row seen without and with its combination
    torch.manual_seed(1)  # the initial weights: the run is repeatable
    Snet = lb.mlp(Pt.shape[1] + sum(nch), sum(nch) + width)
    zeros_t, zeros_v = torch.zeros(len(Pt), sum(nch)), torch.zeros(len(Pv), sum(nch))
    OHt, OHv = onehot(Ct), onehot(Cv)

    def s_loss(X, Z, OH, C, S, V, M, idx):
        o = Snet(torch.cat([torch.cat([X[idx], Z[idx]], 1), torch.cat([X[idx], OH[idx]], 1)], 0))
        b = len(idx)
        ce, k = 0, 0
        for s, n in enumerate(nch):
            l = torch.nn.functional.cross_entropy(o[:b, k:k + n], torch.tensor(C[idx, s]),
                                                  reduction='none')
            ce = ce + (l * S[idx, s]).sum() / S[idx, s].sum().clamp(min=1)
            k += n
        pv = lb.squash(o[:, k:], roles, vals)
        VV, MM = torch.cat([V[idx], V[idx]], 0), torch.cat([M[idx], M[idx]], 0)
        return ce / len(nch) + 10 * ((pv - VV) ** 2 * MM).sum() / MM.sum().clamp(min=1)

    lb.train(Snet, lambda idx: s_loss(Pt, zeros_t, OHt, Ct, St, Vt, Mt, idx), len(Pt), a.epochs,
             lambda: s_loss(Pv, zeros_v, OHv, Cv, Sv, Vv, Mv, allv).item(), seed=1)

    def s_vals(C):
        with torch.no_grad():
            oh = zeros_v if C is None else onehot(C)
            return lb.squash(Snet(torch.cat([Pv, oh], 1))[:, sum(nch):], roles, vals).numpy()

    argmax = np.stack([p.argmax(1) for p in probs], 1)
    picks, right = [], []
    for r in range(len(Pv)):
        combos = top_combos([p[r] for p in probs], a.top_k)
        act = Av[r, sels]
        score = [((np.array(c) == Cv[r]) & act).sum() for c in combos]
        picks.append(combos[int(np.argmax(score))])  # first maximum: the likelier
        right.append(max(score) == act.sum())
    picks = np.array(picks)
    act = Av[:, sels]
    share = lambda C: ((C == Cv) & act).sum() / act.sum()
    r2 = lambda pv: r2_of(pv, Yt, At, Yv, Av, roles, vals)
    print('U: mean selector accuracy (active rows) %.3f; the true active combination is among '
          'the top %d on %d of %d rows' % (acc, a.top_k, sum(right), len(Pv)))
    print('active selectors per row %.1f (median); right in the likeliest combination %.3f, in '
          'the best of the top %d %.3f' % (np.median(act.sum(1)), share(argmax), a.top_k,
                                           share(picks)))
    print('| values | median value R^2 |')
    print('|---|---:|')
    print('| U (unconditional, fit-predictor\'s) | %.3f |' % r2(u_vals))
    print('| C given the true combination (upper bound) | %.3f |' % r2(c_vals(Cv)))
    print('| C given U\'s likeliest combination | %.3f |' % r2(c_vals(argmax)))
    print('| C given the best of U\'s top %d (most correct active selectors) | %.3f |' %
          (a.top_k, r2(c_vals(picks))))
    print('| S without a combination (its U pass) | %.3f |' % r2(s_vals(None)))
    print('| S given the true combination | %.3f |' % r2(s_vals(Cv)))
    print('| S given U\'s likeliest combination | %.3f |' % r2(s_vals(argmax)))
    print('| S given the best of U\'s top %d | %.3f |' % (a.top_k, r2(s_vals(picks))))


if __name__ == '__main__':
    main()
