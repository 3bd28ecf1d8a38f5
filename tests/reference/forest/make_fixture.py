#!/usr/bin/python3
"""Reference fixtures for tests/unit/test_forest.c, made with scikit-learn 1.2.

Run with /usr/bin/python3 (scikit-learn 1.2.1, numpy 1.24) from anywhere; writes next to
this file. Everything is float32 .npy.

exact_*: deterministic trees (bootstrap off, every feature tried at every node) on
continuous random features, for two hyper-parameter sets. scikit-learn's only randomness
there is the order it tries features in, which matters only when two splits are exactly
as good; the script refits with 12 random_states and refuses to write a case whose
held-out predictions change, so the committed predictions are tie-free.

rf_*: a random-forest case (bootstrap, max_features sqrt) for the statistical check:
held-out R^2 (mean over outputs) of scikit-learn for 5 seeds.
"""
import os
import sys

import numpy as np
import sklearn
from sklearn.ensemble import RandomForestRegressor
from sklearn.metrics import r2_score

here = os.path.dirname(os.path.abspath(__file__))


def save(name, a):
    np.save(os.path.join(here, name), np.ascontiguousarray(a, dtype=np.float32))


def targets(X, rng):
    y0 = np.sin(3 * X[:, 0]) + X[:, 1] ** 2 + 0.1 * rng.standard_normal(len(X))
    y1 = np.where(X[:, 2] > 0.2, 1.0, -1.0) * X[:, 3] + 0.1 * rng.standard_normal(len(X))
    y2 = X[:, 0] * X[:, 4] - X[:, 5] + 0.1 * rng.standard_normal(len(X))
    return np.stack([y0, y1, y2], axis=1)


rng = np.random.default_rng(12)
d = 6
X_train = rng.uniform(-1, 1, (240, d)).astype(np.float32)
X_test = rng.uniform(-1, 1, (60, d)).astype(np.float32)
Y_train = targets(X_train, rng).astype(np.float32)
save("exact_X_train.npy", X_train)
save("exact_Y_train.npy", Y_train)
save("exact_X_test.npy", X_test)

cases = {
    # name: (max_depth, min_samples_split, min_samples_leaf)
    "leaf4": (None, 2, 4),
    "depth5": (5, 20, 1),
}
for name, (max_depth, mss, msl) in cases.items():
    preds, imps = [], []
    for rs in range(12):
        m = RandomForestRegressor(n_estimators=1, bootstrap=False, max_features=1.0,
                                  max_depth=max_depth, min_samples_split=mss,
                                  min_samples_leaf=msl, random_state=rs)
        m.fit(X_train, Y_train)
        preds.append(m.predict(X_test))
        imps.append(m.feature_importances_)
    spread = max(np.abs(p - preds[0]).max() for p in preds)
    if spread > 1e-6:
        sys.exit(f"case {name}: predictions depend on feature order (ties), spread {spread}")
    save(f"exact_{name}_pred.npy", preds[0])
    save(f"exact_{name}_importance.npy", imps[0].reshape(1, -1))
    print(f"{name}: {m.estimators_[0].tree_.node_count} nodes, tie-free over 12 seeds")

# Random-forest mode: 8 features (2 tried per node), 3 outputs.
rng = np.random.default_rng(7)
d = 8
X = rng.uniform(-1, 1, (900, d)).astype(np.float32)
Y = targets(X, rng)
Y[:, 1] += X[:, 6]
Y = Y.astype(np.float32)
save("rf_X_train.npy", X[:600])
save("rf_Y_train.npy", Y[:600])
save("rf_X_test.npy", X[600:])
save("rf_Y_test.npy", Y[600:])
r2 = []
for seed in range(5):
    m = RandomForestRegressor(n_estimators=60, max_features="sqrt", min_samples_leaf=2,
                              random_state=seed, n_jobs=2)
    m.fit(X[:600], Y[:600])
    r2.append(r2_score(Y[600:], m.predict(X[600:])))
save("rf_sklearn_r2.npy", np.array(r2).reshape(-1, 1))
print("rf: sklearn", sklearn.__version__, "held-out R^2 per seed", np.round(r2, 4))
