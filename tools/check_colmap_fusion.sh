#!/usr/bin/env bash
# Proves a real client reads planemap's dense outputs: COLMAP's own `stereo_fusion` fuses the
# depth and normal maps `planemap run` writes (stereo/depth_maps, stereo/normal_maps).
#
#   tools/check_colmap_fusion.sh WORKSPACE RUN_OUT
#
# WORKSPACE holds images/ and sparse/ (a `planemap synth` workspace, or any undistorted
# COLMAP model); RUN_OUT is the output directory of `planemap run` on it. Installs Debian's
# `colmap` package when missing (needs root). Exit status 0 when COLMAP fused a non-empty
# point cloud.
set -euo pipefail
ws=$(realpath "$1")
run=$(realpath "$2")
if ! command -v colmap >/dev/null; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq colmap >/dev/null
fi
dense=$(mktemp -d)
trap 'rm -rf "$dense"' EXIT
ln -s "$ws/images" "$dense/images"
mkdir -p "$dense/sparse" "$dense/stereo"
# COLMAP 3.8 reads the model from sparse/ in binary form: the undistorted model the run wrote
# (the maps are in its pinhole cameras), or the workspace's own for runs older than that.
if [ -f "$run/sparse/cameras.bin" ]; then
    cp "$run"/sparse/*.bin "$dense/sparse/"
else
    cp "$ws"/sparse/*.bin "$dense/sparse/"
fi
ln -s "$run/stereo/depth_maps" "$dense/stereo/depth_maps"
ln -s "$run/stereo/normal_maps" "$dense/stereo/normal_maps"
# fusion.cfg: the images to fuse (those planemap labelled), one name per line.
# Names keep their folders (cam0/frame.png), so search the tree.
(cd "$run/stereo/depth_maps" && find . -name '*.geometric.bin' | sed 's|^\./||; s/\.geometric\.bin$//' | sort) > "$dense/stereo/fusion.cfg"
QT_QPA_PLATFORM=offscreen colmap stereo_fusion \
    --workspace_path "$dense" --workspace_format COLMAP --input_type geometric \
    --output_path "$dense/fused.ply" 2>&1 | tail -n 5
count=$(head -c 2000 "$dense/fused.ply" | grep -a '^element vertex' | awk '{print $3}')
echo "colmap stereo_fusion fused ${count:-0} points from $(wc -l < "$dense/stereo/fusion.cfg") planemap depth maps"
[ "${count:-0}" -gt 0 ]
