#!/usr/bin/env python3
"""Generate the seeded benchmark instances of planemap-solvers in the exchange format.

Each instance is a directory of .npy files (see solvers/README.md): unary (N x L, int32),
edges (E x 2, int32, p < q, 4-connected grid in row-major order), edge_weights (E, int32),
pairwise (L x L, int32), init_labels (N, int32: the per-pixel data argmin, so every solver
starts from the same labelling).

Multi-label instances: a piecewise-constant label image (Voronoi cells of random seeds, one
random label per cell), observed with Gaussian noise plus 10 % uniform outliers; the unary
is a truncated absolute difference to the observation; edge weights are contrast-sensitive
(1..4) on a hidden boundary map. Smoothness: Potts or truncated linear.

Binary instance (max-flow alone): a 1024 x 1024 segmentation of a noisy two-tone image with
contrast-sensitive edge weights.

Usage: gen_instances.py OUTDIR [--only NAME ...]
"""
import argparse
import os
import sys

import numpy as np

SEED = 20261123


def grid_edges(h, w):
    idx = np.arange(h * w, dtype=np.int64).reshape(h, w)
    right = np.stack([idx[:, :-1].ravel(), idx[:, 1:].ravel()], axis=1)
    down = np.stack([idx[:-1, :].ravel(), idx[1:, :].ravel()], axis=1)
    return right, down


def voronoi_labels(rng, h, w, cells, num_labels):
    sy = rng.uniform(0, h, cells)
    sx = rng.uniform(0, w, cells)
    lab = rng.integers(0, num_labels, cells)
    yy, xx = np.mgrid[0:h, 0:w]
    best = np.full((h, w), np.inf)
    out = np.zeros((h, w), dtype=np.int64)
    for i in range(cells):
        d = (yy - sy[i]) ** 2 + (xx - sx[i]) ** 2
        m = d < best
        best[m] = d[m]
        out[m] = lab[i]
    return out


def contrast_weights(img, right, down):
    flat = img.ravel()
    w = []
    for e in (right, down):
        diff = np.abs(flat[e[:, 0]] - flat[e[:, 1]])
        w.append(np.where(diff > 0, 1, 4))
    return np.concatenate(w).astype(np.int32)


def save(outdir, name, unary, edges, weights, pairwise, init):
    d = os.path.join(outdir, name)
    os.makedirs(d, exist_ok=True)
    for fname, arr in [
        ("unary.npy", unary),
        ("edges.npy", edges),
        ("edge_weights.npy", weights),
        ("pairwise.npy", pairwise),
        ("init_labels.npy", init),
    ]:
        tmp = os.path.join(d, fname + ".tmp.npy")
        np.save(tmp, np.ascontiguousarray(arr.astype(np.int32)))
        os.replace(tmp, os.path.join(d, fname))
    print(f"wrote {d}: N={unary.shape[0]} L={unary.shape[1]} E={edges.shape[0]}", file=sys.stderr)


def multilabel(outdir, name, h, w, num_labels, smooth, seed):
    rng = np.random.default_rng(seed)
    truth = voronoi_labels(rng, h, w, cells=60, num_labels=num_labels)
    obs = truth + rng.normal(0.0, 1.0 * max(1, num_labels / 16), size=truth.shape)
    outl = rng.random(truth.shape) < 0.10
    obs[outl] = rng.uniform(0, num_labels - 1, size=outl.sum())
    labels = np.arange(num_labels)
    trunc = 4.0 * max(1, num_labels / 16)
    unary = np.rint(10.0 * np.minimum(np.abs(obs.reshape(-1, 1) - labels[None, :]), trunc))
    right, down = grid_edges(h, w)
    edges = np.concatenate([right, down])
    weights = contrast_weights(truth, right, down)
    ld = np.abs(labels[:, None] - labels[None, :])
    if smooth == "potts":
        pairwise = 6 * (ld > 0)
    else:
        pairwise = np.minimum(3 * ld, 12)
    init = unary.argmin(axis=1)
    save(outdir, name, unary, edges, weights, pairwise, init)


def segmentation(outdir, name, n, seed):
    rng = np.random.default_rng(seed)
    truth = voronoi_labels(rng, n // 8, n // 8, cells=40, num_labels=2)
    truth = np.kron(truth, np.ones((8, 8), dtype=np.int64))
    img = 0.3 + 0.4 * truth + rng.normal(0.0, 0.25, size=truth.shape)
    unary = np.stack([np.abs(img - 0.3), np.abs(img - 0.7)], axis=-1).reshape(-1, 2)
    unary = np.rint(100.0 * unary)
    right, down = grid_edges(n, n)
    edges = np.concatenate([right, down])
    flat = img.ravel()
    diff = np.concatenate([flat[e[:, 0]] - flat[e[:, 1]] for e in (right, down)])
    weights = np.rint(1 + 30.0 * np.exp(-(diff ** 2) / (2 * 0.2 ** 2)))
    pairwise = np.array([[0, 1], [1, 0]])
    init = unary.argmin(axis=1)
    save(outdir, name, unary, edges, weights, pairwise, init)


INSTANCES = {
    "g288x384_L16_potts": lambda o: multilabel(o, "g288x384_L16_potts", 288, 384, 16, "potts", SEED + 1),
    "g288x384_L16_tlin": lambda o: multilabel(o, "g288x384_L16_tlin", 288, 384, 16, "tlin", SEED + 2),
    "g480x640_L16_potts": lambda o: multilabel(o, "g480x640_L16_potts", 480, 640, 16, "potts", SEED + 3),
    "g480x640_L16_tlin": lambda o: multilabel(o, "g480x640_L16_tlin", 480, 640, 16, "tlin", SEED + 4),
    "g480x640_L64_potts": lambda o: multilabel(o, "g480x640_L64_potts", 480, 640, 64, "potts", SEED + 5),
    "g480x640_L64_tlin": lambda o: multilabel(o, "g480x640_L64_tlin", 480, 640, 64, "tlin", SEED + 6),
    "seg1024": lambda o: segmentation(o, "seg1024", 1024, SEED + 7),
}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("outdir")
    ap.add_argument("--only", nargs="*", default=None)
    args = ap.parse_args()
    for name, make in INSTANCES.items():
        if args.only is None or name in args.only:
            make(args.outdir)


if __name__ == "__main__":
    main()
