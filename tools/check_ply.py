#!/usr/bin/env python3
"""Proves that a real PLY client opens planemap's PLY outputs.

Usage: python3 tools/check_ply.py FILE.ply [FILE.ply ...]

Creates (once) a virtual environment in target/ply-venv with trimesh and numpy from PyPI,
then loads each file with trimesh and prints what it found. A point cloud must load as a
trimesh.PointCloud (with colours if the file has them), a mesh as a trimesh.Trimesh with the
same vertex and face counts as its header. Exits non-zero on the first file that fails.
"""
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
VENV = os.path.join(HERE, "..", "target", "ply-venv")
PY = os.path.join(VENV, "bin", "python")


def ensure_venv():
    if not os.path.exists(PY):
        subprocess.check_call([sys.executable, "-m", "venv", VENV])
        subprocess.check_call([PY, "-m", "pip", "install", "-q", "numpy", "trimesh"])


def header_counts(path):
    """Element counts, plus "_colors": whether the vertex element has red/green/blue."""
    counts = {"_colors": False}
    with open(path, "rb") as f:
        for raw in f:
            line = raw.decode("ascii").strip()
            if line.startswith("element "):
                _, name, count = line.split()
                counts[name] = int(count)
            if line == "property uchar red":
                counts["_colors"] = True
            if line == "end_header":
                break
    return counts


def check(path):
    import trimesh

    counts = header_counts(path)
    loaded = trimesh.load(path, process=False)
    if counts.get("face", 0) > 0:
        assert isinstance(loaded, trimesh.Trimesh), type(loaded)
        assert len(loaded.vertices) == counts["vertex"], (len(loaded.vertices), counts)
        assert len(loaded.faces) == counts["face"], (len(loaded.faces), counts)
        print(f"{path}: mesh with {len(loaded.vertices)} vertices, {len(loaded.faces)} faces")
    else:
        assert isinstance(loaded, trimesh.PointCloud), type(loaded)
        assert len(loaded.vertices) == counts["vertex"], (len(loaded.vertices), counts)
        if counts["_colors"]:
            assert len(loaded.colors) == counts["vertex"], "colours not loaded"
        print(f"{path}: point cloud with {len(loaded.vertices)} points, "
              f"first {loaded.vertices[0].tolist()}")


def main():
    if os.environ.get("CHECK_PLY_IN_VENV") != "1":
        ensure_venv()
        env = dict(os.environ, CHECK_PLY_IN_VENV="1")
        sys.exit(subprocess.call([PY, os.path.abspath(__file__)] + sys.argv[1:], env=env))
    for path in sys.argv[1:]:
        check(path)


if __name__ == "__main__":
    main()
