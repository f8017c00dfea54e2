#!/usr/bin/env python3
"""Build a small COLMAP reconstruction *in pycolmap* and write it as a test fixture.

Usage:  python3 tools/make_pycolmap_fixture.py [OUT_DIR]
        (default OUT_DIR: tests/fixtures/pycolmap_small)

Writes OUT_DIR/bin (cameras.bin, images.bin, points3D.bin, plus whatever else pycolmap
writes, e.g. rigs.bin / frames.bin), OUT_DIR/txt (the same in text), and
OUT_DIR/expected.json with every value read back from pycolmap's own objects. Floats in the
JSON are strings holding Python's repr(), which round-trips exactly, so the Rust test can
compare bit for bit without depending on a JSON float parser.

If pycolmap is not importable, the script creates a virtualenv (default
/tmp/planemap-pycolmap-venv, override with PYCOLMAP_VENV), pip-installs pycolmap
(PYCOLMAP_SPEC, default "pycolmap") and re-runs itself there. The scene is generated from a
fixed seed, so re-running with the same pycolmap version gives the same files.
"""
import json
import os
import subprocess
import sys
import venv
from pathlib import Path

VENV = Path(os.environ.get("PYCOLMAP_VENV", "/tmp/planemap-pycolmap-venv"))


def ensure_pycolmap():
    try:
        import pycolmap  # noqa: F401
        return
    except ImportError:
        pass
    if os.environ.get("PLANEMAP_FIXTURE_REEXEC"):
        sys.exit("pycolmap still not importable inside the virtualenv")
    py = VENV / "bin" / "python"
    if not py.exists():
        print(f"creating virtualenv {VENV}", file=sys.stderr)
        venv.EnvBuilder(with_pip=True).create(VENV)
    spec = os.environ.get("PYCOLMAP_SPEC", "pycolmap")
    subprocess.check_call([str(py), "-m", "pip", "install", "-q", spec, "numpy"])
    env = dict(os.environ, PLANEMAP_FIXTURE_REEXEC="1")
    os.execve(str(py), [str(py), *sys.argv], env)


def look_at(eye, target, up):
    """cam_from_world rotation matrix and translation: x right, y down, z forward."""
    import numpy as np

    z = target - eye
    z = z / np.linalg.norm(z)
    x = np.cross(z, up)
    x = x / np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])  # rows: camera axes in world
    t = -R @ eye
    return R, t


def build(pycolmap, np):
    rng = np.random.default_rng(20261123)
    rec = pycolmap.Reconstruction()

    # Several cameras of different models, two of them distorted.
    cams = [
        (1, "SIMPLE_PINHOLE", 640, 480, [520.0, 320.0, 240.0]),
        (2, "PINHOLE", 800, 600, [610.5, 612.25, 401.0, 299.5]),
        (3, "SIMPLE_RADIAL", 640, 480, [515.0, 319.5, 239.5, -0.0123]),
        (4, "OPENCV", 1024, 768, [800.1, 801.7, 512.3, 383.9, -0.081, 0.012, 0.0007, -0.0004]),
    ]
    for cid, model, w, h, params in cams:
        cam = pycolmap.Camera(
            camera_id=cid, model=model, width=w, height=h, params=np.array(params)
        )
        rec.add_camera_with_trivial_rig(cam)

    # ~50 points in a box around the origin, with colours.
    npts = 50
    xyz = rng.uniform([-1.0, -1.0, -0.5], [1.0, 1.0, 0.5], size=(npts, 3))
    colors = rng.integers(0, 256, size=(npts, 3), dtype=np.uint8)

    # 5 images on an arc around the scene; image 5 reuses camera 3. Ids are not 1..N on
    # purpose (file order = sorted ids, views must be sorted by id).
    image_specs = [
        (1, 1, "img_01.png", np.array([4.0, 0.3, 1.0])),
        (2, 2, "img_02.png", np.array([3.0, 2.8, 1.4])),
        (4, 3, "img_04.png", np.array([0.5, 4.1, 0.8])),
        (7, 4, "sub/img_07.png", np.array([-2.9, 2.9, 1.9])),
        (9, 3, "img_09.png", np.array([-4.0, 0.2, 0.6])),
    ]
    up = np.array([0.0, 0.0, 1.0])
    obs = {}  # image_id -> list of (xy, point index or None)
    poses = {}
    for image_id, cam_id, name, eye in image_specs:
        R, t = look_at(eye, rng.normal(0, 0.05, 3), up)
        pose = pycolmap.Rigid3d(pycolmap.Rotation3d(R), t)
        poses[image_id] = pose
        cam = rec.camera(cam_id)
        kps = []
        for i in range(npts):
            # Each image sees ~70% of the points.
            if rng.uniform() < 0.3:
                continue
            p_cam = pose * xyz[i]
            xy = cam.img_from_cam(p_cam)
            xy = np.asarray(xy, dtype=float).reshape(-1)[:2] + rng.normal(0, 0.4, 2)
            kps.append((xy, i))
        # A few keypoints that are not triangulated (point3D id invalid).
        for _ in range(3):
            kps.append((rng.uniform([0, 0], [cam.width, cam.height]), None))
        obs[image_id] = kps
        image = pycolmap.Image(
            name=name,
            keypoints=np.array([k[0] for k in kps]),
            camera_id=cam_id,
            image_id=image_id,
        )
        rec.add_image_with_trivial_frame(image, pose)

    for i in range(npts):
        track = pycolmap.Track()
        for image_id, kps in obs.items():
            for idx, (_, pi) in enumerate(kps):
                if pi == i:
                    track.add_element(image_id, idx)
        if track.length() == 0:
            continue
        rec.add_point3D(xyz[i], track, colors[i])
    rec.update_point_3d_errors()
    return rec


def r(x):
    return repr(float(x))


def quat_wxyz(rigid):
    q = rigid.rotation.quat  # x, y, z, w
    return [q[3], q[0], q[1], q[2]]


def expected(pycolmap, rec):
    out = {
        "pycolmap_version": pycolmap.__version__,
        "note": "floats are repr() strings; qvec is (w, x, y, z) of cam_from_world",
        "cameras": [],
        "images": [],
        "points3D": [],
    }
    for cid in sorted(rec.cameras):
        c = rec.cameras[cid]
        out["cameras"].append(
            {
                "camera_id": cid,
                "model": c.model.name,
                "width": c.width,
                "height": c.height,
                "params": [r(v) for v in c.params],
            }
        )
    for iid in sorted(rec.images):
        im = rec.images[iid]
        pose = im.cam_from_world() if callable(im.cam_from_world) else im.cam_from_world
        pts = []
        for p in im.points2D:
            pid = p.point3D_id if p.has_point3D() else -1
            pts.append([r(p.xy[0]), r(p.xy[1]), int(pid)])
        out["images"].append(
            {
                "image_id": iid,
                "camera_id": im.camera_id,
                "name": im.name,
                "qvec": [r(v) for v in quat_wxyz(pose)],
                "tvec": [r(v) for v in pose.translation],
                "points2D": pts,
            }
        )
    for pid in sorted(rec.points3D):
        p = rec.points3D[pid]
        out["points3D"].append(
            {
                "point3D_id": pid,
                "xyz": [r(v) for v in p.xyz],
                "rgb": [int(v) for v in p.color],
                "error": r(p.error),
                "track": [[e.image_id, e.point2D_idx] for e in p.track.elements],
            }
        )
    return out


def main():
    ensure_pycolmap()
    import numpy as np
    import pycolmap

    root = Path(__file__).resolve().parent.parent
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else root / "tests/fixtures/pycolmap_small"
    rec = build(pycolmap, np)
    print(rec.summary())
    (out / "bin").mkdir(parents=True, exist_ok=True)
    (out / "txt").mkdir(parents=True, exist_ok=True)
    rec.write_binary(str(out / "bin"))
    rec.write_text(str(out / "txt"))
    # Read back what pycolmap itself wrote, so expected.json describes the files.
    back = pycolmap.Reconstruction()
    back.read_binary(str(out / "bin"))
    exp = expected(pycolmap, back)
    (out / "expected.json").write_text(json.dumps(exp, indent=1) + "\n")
    print(f"wrote {out} with pycolmap {pycolmap.__version__}")


if __name__ == "__main__":
    main()
