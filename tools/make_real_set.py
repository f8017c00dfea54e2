#!/usr/bin/env python3
"""Make a real set for `planemap bench --real` from any COLMAP reconstruction.

Usage:  python3 tools/make_real_set.py MODEL_DIR IMAGES_DIR OUT_DIR [--fraction 0.2] [--seed 0]
                                       [--min-track 3]

Writes, as ../shared/data/real/ holds them:
  OUT_DIR/sparse/        the model without the held-out points (binary, written by pycolmap;
                         their 2D observations stay in images.bin, untriangulated);
  OUT_DIR/heldout.json   the held-out points: [{id, xyz, obs: [[image_name, x, y], ...]}],
                         x, y in COLMAP pixel coordinates (top-left pixel centre at 0.5, 0.5);
  OUT_DIR/images         a symbolic link to IMAGES_DIR (the photographs are not copied).

Held out: a random `--fraction` of the points seen by at least `--min-track` images (a point
seen twice is barely constrained: a poor ground truth), drawn with `--seed`. Their depth in a
view is their camera-frame z; they lie only where features are (textured places), never on
plain paint or sky, so they score the textured parts of a capture.

If pycolmap is not importable, the script creates a virtualenv (PYCOLMAP_VENV, default
/tmp/planemap-pycolmap-venv), pip-installs pycolmap (PYCOLMAP_SPEC) and re-runs itself there.
"""
import argparse
import json
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_pycolmap_fixture import ensure_pycolmap  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("model", type=Path, help="COLMAP model folder (binary or text)")
    ap.add_argument("images", type=Path, help="the model's images folder")
    ap.add_argument("out", type=Path, help="output folder (must not exist or be empty)")
    ap.add_argument("--fraction", type=float, default=0.2, help="share of points held out")
    ap.add_argument("--seed", type=int, default=0, help="random seed of the draw")
    ap.add_argument("--min-track", type=int, default=3, help="least track length held out")
    a = ap.parse_args()
    if not 0.0 < a.fraction < 1.0:
        sys.exit(f"--fraction must be in (0, 1), got {a.fraction}")
    if not a.images.is_dir():
        sys.exit(f"{a.images}: not a folder of images")
    if a.out.exists() and any(a.out.iterdir()):
        sys.exit(f"{a.out}: exists and is not empty (nothing is overwritten)")
    ensure_pycolmap()
    import numpy as np
    import pycolmap

    rec = pycolmap.Reconstruction(str(a.model))
    names = {img_id: img.name for img_id, img in rec.images.items()}
    eligible = sorted(
        pid for pid, p in rec.points3D.items() if p.track.length() >= a.min_track
    )
    if not eligible:
        sys.exit(f"{a.model}: no point is seen by {a.min_track} or more images")
    rng = np.random.default_rng(a.seed)
    count = max(1, int(round(a.fraction * len(eligible))))
    held = sorted(int(i) for i in rng.choice(eligible, size=count, replace=False))
    points = []
    for pid in held:
        p = rec.points3D[pid]
        obs = []
        for el in p.track.elements:
            img = rec.images[el.image_id]
            xy = img.points2D[el.point2D_idx].xy
            obs.append([names[el.image_id], float(xy[0]), float(xy[1])])
        points.append({"id": pid, "xyz": [float(c) for c in p.xyz], "obs": obs})
    for pid in held:
        rec.delete_point3D(pid)
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / "sparse").mkdir()
    rec.write(str(a.out / "sparse"))
    tmp = a.out / "heldout.json.tmp"
    tmp.write_text(json.dumps(points))
    os.replace(tmp, a.out / "heldout.json")
    os.symlink(a.images.resolve(), a.out / "images")
    n_obs = sum(len(p["obs"]) for p in points)
    print(
        f"{a.out}: {len(rec.points3D)} points kept, {len(points)} held out "
        f"({n_obs} observations) of {len(eligible)} seen by >= {a.min_track} images"
    )


if __name__ == "__main__":
    main()
