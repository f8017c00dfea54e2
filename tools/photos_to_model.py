#!/usr/bin/env python3
"""From a folder of photographs to a COLMAP model planemap reads, with pycolmap.

Usage:  python3 tools/photos_to_model.py IMAGES_DIR OUT_DIR [--camera-model SIMPLE_RADIAL]
                                         [--max-features 8192] [--single-camera]

Runs pycolmap's SIFT feature extraction, exhaustive matching and incremental mapping (the
same steps as `colmap feature_extractor`, `exhaustive_matcher` and `mapper`) and writes:
  OUT_DIR/database.db      the features and matches;
  OUT_DIR/sparse/          the largest reconstruction, binary (cameras, images, points3D);
then prints the `planemap run` command for it. Distorted cameras (SIMPLE_RADIAL, the default,
as COLMAP's) are undistorted by planemap on load.

Exhaustive matching is quadratic in the number of images: fine up to a few hundred. If
pycolmap is not importable, the script creates a virtualenv (PYCOLMAP_VENV, default
/tmp/planemap-pycolmap-venv), pip-installs pycolmap (PYCOLMAP_SPEC) and re-runs itself there.
"""
import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_pycolmap_fixture import ensure_pycolmap  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("images", type=Path, help="folder of photographs (JPEG, PNG)")
    ap.add_argument("out", type=Path, help="output folder (must not exist or be empty)")
    ap.add_argument("--camera-model", default="SIMPLE_RADIAL", help="COLMAP camera model")
    ap.add_argument("--max-features", type=int, default=8192, help="SIFT features per image")
    ap.add_argument(
        "--single-camera", action="store_true", help="all photographs share one camera"
    )
    a = ap.parse_args()
    if not a.images.is_dir():
        sys.exit(f"{a.images}: not a folder")
    if a.out.exists() and any(a.out.iterdir()):
        sys.exit(f"{a.out}: exists and is not empty (nothing is overwritten)")
    ensure_pycolmap()
    import pycolmap

    a.out.mkdir(parents=True, exist_ok=True)
    db = a.out / "database.db"
    extraction = pycolmap.FeatureExtractionOptions()
    extraction.sift.max_num_features = a.max_features
    mode = (
        pycolmap.CameraMode.SINGLE if a.single_camera else pycolmap.CameraMode.AUTO
    )
    print("extracting features", file=sys.stderr)
    reader = pycolmap.ImageReaderOptions()
    reader.camera_model = a.camera_model
    pycolmap.extract_features(
        db,
        a.images,
        camera_mode=mode,
        reader_options=reader,
        extraction_options=extraction,
    )
    print("matching (exhaustive)", file=sys.stderr)
    pycolmap.match_exhaustive(db)
    print("mapping", file=sys.stderr)
    work = a.out / "mapper"
    work.mkdir()
    maps = pycolmap.incremental_mapping(db, a.images, work)
    if not maps:
        sys.exit("the mapper reconstructed nothing: too few matches between the photographs")
    best = max(maps.values(), key=lambda r: r.num_reg_images())
    sparse = a.out / "sparse"
    sparse.mkdir()
    best.write(str(sparse))
    print(
        f"{sparse}: {best.num_reg_images()} of {len(list(a.images.iterdir()))} images "
        f"registered, {best.num_points3D()} points",
        file=sys.stderr,
    )
    print(f"planemap run --model {sparse} --images {a.images} -o {a.out / 'planemap'}")


if __name__ == "__main__":
    main()
