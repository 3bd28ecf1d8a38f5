#!/usr/bin/python3
"""How far can an image say what a parameter was? (issue 15: why R^2 stays low)

For each of N dataset samples, renders the sample's own parameters, the same parameters at
another Pattern Offset (the floor: the same material, the pattern moved), and, for every
active value parameter, the parameters with that one value moved by DELTA (towards the
middle of its range). All renders use the sample's datagen preset and seed, so the
renderer's noise is the same in every variant and only the parameter change differs.
Each render is described as datagen describes (MobileNetV2 Grams) and mapped into the
bundled model's input space (signed log, standardise, whitened PCA: what the predictor
sees). A parameter moved by DELTA whose descriptor moves less than the floor's cannot be
told from the pattern's seed: no predictor can place it closer than about DELTA there.

    /usr/bin/python3 scripts/identifiability.py --dataset ds.sqlite --ids 3488:3528 \
        --delta 0.3 -o ident/            # writes ident/ratios-{pca,gram}.csv and prints the table

Needs numpy (Debian's python3-numpy) and a built imsynth (build/cli/imsynth or --imsynth).
Resumable: renders already in OUT/ are reused.
"""
import argparse, json, os, sqlite3, struct, subprocess, sys
from concurrent.futures import ThreadPoolExecutor
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def safetensors(path):
    with open(path, 'rb') as f:
        n = struct.unpack('<Q', f.read(8))[0]
        head = json.loads(f.read(n))
        data = f.read()
    out = {}
    for k, v in head.items():
        if k == '__metadata__':
            continue
        a, b = v['data_offsets']
        dt = {'F32': np.float32, 'F16': np.float16}[v['dtype']]
        out[k] = np.frombuffer(data[a:b], dt).reshape(v['shape']).astype(np.float32)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--dataset', required=True)
    ap.add_argument('--ids', required=True, help='FIRST:END (end exclusive)')
    ap.add_argument('--delta', type=float, default=0.3)
    ap.add_argument('--model', default=os.path.join(ROOT, 'assets/model'))
    ap.add_argument('--imsynth', default=os.path.join(ROOT, 'build/cli/imsynth'))
    ap.add_argument('--jobs', type=int, default=1)
    ap.add_argument('-o', '--out', required=True)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    model = json.load(open(os.path.join(a.model, 'model.json')))
    names, roles = model['parameters'], model['roles']
    preset = model['dataset']['config']['preset']
    offset = names.index('Pattern Offset')
    first, end = (int(x) for x in a.ids.split(':'))
    db = sqlite3.connect('file:%s?mode=ro' % a.dataset, uri=True)

    jobs = []  # (id, variant name, params, seed)
    for sid in range(first, end):
        row = db.execute('SELECT params, active FROM samples WHERE id = ? AND view = 0',
                         (sid,)).fetchone()
        if row is None:
            sys.exit('%s: no sample %d' % (a.dataset, sid))
        p = np.frombuffer(row[0], np.float32).astype(np.float64)
        act = np.frombuffer(row[1], np.uint8)
        seed = sid * 16  # datagen's "id * 16 + view", view 0
        jobs.append((sid, 'base', p, seed))
        q = p.copy(); q[offset] = (q[offset] + 0.5) % 1.0
        jobs.append((sid, 'offset', q, seed))
        for i, r in enumerate(roles):
            if r in ('value', 'hue') and act[i]:
                q = p.copy()
                if r == 'hue':  # a hue is on a circle: DELTA of a turn either way
                    q[i] = (q[i] + a.delta) % 1.0
                else:
                    q[i] += a.delta if q[i] < 0.5 else -a.delta
                jobs.append((sid, names[i], q, seed))

    def render(job):
        sid, var, p, seed = job
        stem = os.path.join(a.out, '%d-%s' % (sid, var.replace(' ', '_')))
        if os.path.exists(stem + '.exr'):
            return stem + '.exr'
        with open(stem + '.json', 'w') as f:
            json.dump({n: float(v) for n, v in zip(names, p)}, f)
        subprocess.run([a.imsynth, 'render', os.path.join(ROOT, 'assets/supershader.json'),
                        '--params', stem + '.json', '-o', stem + '.exr', '--float',
                        '--spp', str(preset['spp']), '--max-spp', str(preset['max_spp']),
                        '--light-samples', str(preset['light_samples']),
                        '--seed', str(seed), '--threads', '1'], check=True)
        return stem + '.exr'

    with ThreadPoolExecutor(a.jobs) as ex:
        files = list(ex.map(render, jobs))
    npy = os.path.join(a.out, 'descriptors.npy')
    subprocess.run([a.imsynth, 'describe', *files, '--features', 'mobilenetv2', '-o', npy],
                   check=True, stdout=subprocess.DEVNULL)
    X = np.load(npy).astype(np.float64)

    t = safetensors(os.path.join(a.model, 'transform.safetensors'))
    s = t['signed_log.scale']
    z = (np.sign(X) * np.log1p(np.abs(X) / s) - t['standardise.mean']) / t['standardise.std']
    spaces = {'whitened PCA (the predictor input)': (z @ t['pca.components'].T) /
              np.sqrt(t['pca.variance']), 'standardised Gram values (no PCA)': z}
    for label, Z in spaces.items():
        report(a, jobs, Z, label, model, first, end)


def report(a, jobs, Z, label, model, first, end):
    """Per (sample, parameter), ratio and snr; per parameter, consistency and confusion
    (below):
    ratio: |move| / |floor|, Euclidean in this space: is the move bigger than the whole
        change another Pattern Offset makes?
    snr: the move's length over the pattern's noise along the move's own direction, the
        noise's per-component variance pooled over the samples' offset pairs (a difference
        of two draws has twice a draw's variance). The best a linear read-out along that
        one direction can do, ignoring every other parameter's confusion: optimistic."""
    base = {sid: Z[k] for k, (sid, var, _, _) in enumerate(jobs) if var == 'base'}
    base_p = {sid: p for sid, var, p, _ in jobs if var == 'base'}
    names = model['parameters']
    off = {sid: Z[k] - base[sid] for k, (sid, var, _, _) in enumerate(jobs) if var == 'offset'}
    floor = {sid: np.linalg.norm(d) for sid, d in off.items()}
    noise_var = np.mean([d * d for d in off.values()], axis=0) / 2
    ratios, snrs, moves = {}, {}, {}
    csv = 'ratios-pca.csv' if 'PCA' in label else 'ratios-gram.csv'
    with open(os.path.join(a.out, csv), 'w') as f:
        f.write('id,parameter,distance,floor,ratio,snr\n')
        for k, (sid, var, p, _) in enumerate(jobs):
            if var in ('base', 'offset'):
                continue
            move = Z[k] - base[sid]
            i = names.index(var)
            up = 1.0 if p[i] > base_p[sid][i] or 'Hue' in var else -1.0  # hues move up
            d = np.linalg.norm(move)
            sd = np.sqrt(np.sum(move * move * noise_var)) / d if d > 0 else np.inf
            snr = d / sd if d > 0 else 0.0
            moves.setdefault(var, {})[sid] = up * move / d if d > 0 else move
            ratios.setdefault(var, []).append(d / floor[sid])
            snrs.setdefault(var, []).append(snr)
            f.write('%d,%s,%.5g,%.5g,%.5g,%.5g\n' % (sid, var, d, floor[sid], d / floor[sid], snr))
    # consistency: the mean cosine between one parameter's move directions (towards larger
    # values) on two different samples (1: one direction everywhere, what a linear read-out needs; 0: it depends on
    # the other parameters). confusion: on one sample, the largest |cosine| between this
    # parameter's move and another parameter's (1: the image cannot tell them apart).
    consistency, confusion = {}, {}
    for n, per in moves.items():
        v = np.array(list(per.values()))
        c = v @ v.T
        k = len(v)
        consistency[n] = (c.sum() - np.trace(c)) / (k * (k - 1)) if k > 1 else np.nan
        worst = []
        for sid, u in per.items():
            others = [moves[m][sid] for m in moves if m != n and sid in moves[m]]
            if others:
                worst.append(np.max(np.abs(np.array(others) @ u)))
        confusion[n] = np.median(worst) if worst else np.nan
    r2 = model['result'].get('val_value_r2', {})
    print('\n%d samples (ids %d-%d), delta %.2f, in %s' % (end - first, first, end - 1, a.delta,
                                                        label))
    print('| parameter | active in | median ratio | ratio < 1 | median snr | snr < 1 | '
          'consistency | confusion | bundled model R^2 |')
    print('|---|---:|---:|---:|---:|---:|---:|---:|---:|')
    all_r, all_s = [], []
    for n in sorted(ratios, key=lambda n: np.median(snrs[n])):
        r, q = np.array(ratios[n]), np.array(snrs[n])
        all_r += list(r)
        all_s += list(q)
        print('| %s | %d | %.2f | %.0f%% | %.2f | %.0f%% | %.2f | %.2f | %s |' % (
            n, len(r), np.median(r), 100 * np.mean(r < 1), np.median(q), 100 * np.mean(q < 1),
            consistency[n], confusion[n], '%.2f' % r2[n] if n in r2 else '-'))
    all_r, all_s = np.array(all_r), np.array(all_s)
    print('all %d (sample, parameter) pairs: ratio < 1 in %.0f%%, snr < 1 in %.0f%%, snr < 2 in '
          '%.0f%%; median floor %.3g' % (len(all_r), 100 * np.mean(all_r < 1),
                                       100 * np.mean(all_s < 1), 100 * np.mean(all_s < 2),
                                       np.median(list(floor.values()))))
    moved = sorted(moves)
    x = np.array([np.median(snrs[n]) for n in moved])
    y = np.array([r2.get(n, np.nan) for n in moved])
    for lab, z in (('median snr', x), ('consistency', np.array([consistency[n] for n in moved])),
                   ('confusion', np.array([confusion[n] for n in moved]))):
        ok = np.isfinite(y) & np.isfinite(z)
        if ok.sum() > 2:
            rz = np.argsort(np.argsort(z[ok])); ry = np.argsort(np.argsort(y[ok]))
            print('Spearman correlation of %s with the bundled model R^2 over %d parameters: %.2f'
                  % (lab, ok.sum(), np.corrcoef(rz, ry)[0, 1]))


if __name__ == '__main__':
    main()
