#!/usr/bin/env python3
"""Check that pycolmap (a real COLMAP client) reads a planemap-written sparse model.

Usage:  python3 tools/check_pycolmap.py MODEL_DIR [--text TXT_DIR]

MODEL_DIR holds cameras.bin, images.bin, points3D.bin written by planemap. The text version
of the same model (cameras.txt, images.txt, points3D.txt) is looked for in TXT_DIR, else in
MODEL_DIR itself. The binary model is loaded with pycolmap; the text model is parsed here in
plain Python (no COLMAP code involved), and the two must agree: same image ids, names and
camera ids, same point ids and track lengths, and poses (qvec, tvec) and point positions
equal to 1e-12; pycolmap must also read the text files to exactly the binary values. Exit status 0 when they agree, 1 with a list of differences otherwise.

Like make_pycolmap_fixture.py, it creates a virtualenv with pycolmap when pycolmap is not
importable (PYCOLMAP_VENV, default /tmp/planemap-pycolmap-venv).
"""
import argparse
import os
import subprocess
import sys
import venv
from pathlib import Path

VENV = Path(os.environ.get("PYCOLMAP_VENV", "/tmp/planemap-pycolmap-venv"))
TOL = 1e-12


def ensure_pycolmap():
    try:
        import pycolmap  # noqa: F401
        return
    except ImportError:
        pass
    if os.environ.get("PLANEMAP_CHECK_REEXEC"):
        sys.exit("pycolmap still not importable inside the virtualenv")
    py = VENV / "bin" / "python"
    if not py.exists():
        venv.EnvBuilder(with_pip=True).create(VENV)
    subprocess.check_call([str(py), "-m", "pip", "install", "-q",
                           os.environ.get("PYCOLMAP_SPEC", "pycolmap"), "numpy"])
    env = dict(os.environ, PLANEMAP_CHECK_REEXEC="1")
    os.execve(str(py), [str(py), *sys.argv], env)


def data_lines(path):
    with open(path) as f:
        return [l.rstrip("\n") for l in f]


def parse_text(d):
    """(images, points) from COLMAP text files, in plain Python."""
    images = {}
    lines = data_lines(d / "images.txt")
    i = 0
    while i < len(lines):
        s = lines[i].strip()
        if not s or s.startswith("#"):
            i += 1
            continue
        f = s.split()
        images[int(f[0])] = {
            "qvec": [float(v) for v in f[1:5]],
            "tvec": [float(v) for v in f[5:8]],
            "camera_id": int(f[8]),
            "name": f[9],
            "num_points2D": len(lines[i + 1].split()) // 3 if i + 1 < len(lines) else 0,
        }
        i += 2
    points = {}
    for s in data_lines(d / "points3D.txt"):
        s = s.strip()
        if not s or s.startswith("#"):
            continue
        f = s.split()
        points[int(f[0])] = {
            "xyz": [float(v) for v in f[1:4]],
            "track_length": (len(f) - 8) // 2,
        }
    return images, points


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("model_dir", type=Path)
    ap.add_argument("--text", type=Path, default=None)
    args = ap.parse_args()
    ensure_pycolmap()
    import pycolmap

    txt_dir = args.text or args.model_dir
    images, points = parse_text(txt_dir)
    rec = pycolmap.Reconstruction()
    rec.read_binary(str(args.model_dir))
    problems = []

    def check(cond, msg):
        if not cond:
            problems.append(msg)

    check(rec.num_images() == len(images), f"image count: pycolmap {rec.num_images()}, text {len(images)}")
    check(rec.num_points3D() == len(points), f"point count: pycolmap {rec.num_points3D()}, text {len(points)}")
    for iid, t in images.items():
        if iid not in rec.images:
            problems.append(f"image {iid} missing in pycolmap")
            continue
        im = rec.images[iid]
        pose = im.cam_from_world() if callable(im.cam_from_world) else im.cam_from_world
        q = pose.rotation.quat  # x, y, z, w
        qvec = [q[3], q[0], q[1], q[2]]
        check(im.name == t["name"], f"image {iid} name {im.name!r} vs {t['name']!r}")
        check(im.camera_id == t["camera_id"], f"image {iid} camera {im.camera_id} vs {t['camera_id']}")
        check(im.num_points2D() == t["num_points2D"], f"image {iid} 2D points {im.num_points2D()} vs {t['num_points2D']}")
        for a, b in zip(qvec, t["qvec"]):
            check(abs(a - b) <= TOL, f"image {iid} qvec {qvec} vs {t['qvec']}")
        for a, b in zip(pose.translation, t["tvec"]):
            check(abs(a - b) <= TOL, f"image {iid} tvec {list(pose.translation)} vs {t['tvec']}")
    for pid, t in points.items():
        if pid not in rec.points3D:
            problems.append(f"point {pid} missing in pycolmap")
            continue
        p = rec.points3D[pid]
        check(p.track.length() == t["track_length"], f"point {pid} track {p.track.length()} vs {t['track_length']}")
        for a, b in zip(p.xyz, t["xyz"]):
            check(abs(a - b) <= TOL, f"point {pid} xyz {list(p.xyz)} vs {t['xyz']}")
    # pycolmap must also read our text files, to the same values as our binary files.
    rec_txt = pycolmap.Reconstruction()
    rec_txt.read_text(str(txt_dir))
    for iid in rec.images:
        a = rec.images[iid]
        b = rec_txt.images[iid] if iid in rec_txt.images else None
        if b is None:
            problems.append(f"image {iid} missing from pycolmap's reading of the text model")
            continue
        pa = a.cam_from_world() if callable(a.cam_from_world) else a.cam_from_world
        pb = b.cam_from_world() if callable(b.cam_from_world) else b.cam_from_world
        check((pa.matrix() == pb.matrix()).all(), f"image {iid}: text and binary poses differ in pycolmap")
    check(rec_txt.num_points3D() == rec.num_points3D(), "pycolmap reads different point counts from text and binary")
    if problems:
        print(f"FAIL: {len(problems)} differences", file=sys.stderr)
        for p in problems[:50]:
            print("  " + p, file=sys.stderr)
        sys.exit(1)
    print(f"OK: pycolmap {pycolmap.__version__} read {rec.num_cameras()} cameras, "
          f"{rec.num_images()} images, {rec.num_points3D()} points; poses and points match the text model")


if __name__ == "__main__":
    main()
