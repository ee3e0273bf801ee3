#!/bin/sh
# Regenerates the project meshes in meshes/ from the scripts in this directory.
# Needs gmsh (4.8), tetgen (1.5) and /usr/bin/python3 with the vtk module.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
out=$(dirname "$here")
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

gmsh -v 1 -3 "$here/ellipsoid.geo" -format msh22 -o "$out/ellipsoid_v22.msh"
gmsh -v 1 -3 "$here/holed_block.geo" -format msh41 -o "$out/holed_block_v41.msh"

# TetGen fills a Gmsh surface mesh of the sphere (q1.414: radius-edge ratio bound).
gmsh -v 1 -2 "$here/sphere_surface.geo" -format stl -o "$scratch/sphere.stl"
(cd "$scratch" && tetgen -pq1.414Q sphere.stl >/dev/null)
cp "$scratch/sphere.1.node" "$out/sphere_tetgen.node"
cp "$scratch/sphere.1.ele" "$out/sphere_tetgen.ele"

# Gmsh's VTK output also holds the points, lines and triangles of the model, which the reader
# has to skip; VTK itself writes the binary copy (in the VTK 5.1 OFFSETS/CONNECTIVITY layout).
gmsh -v 1 -3 "$here/beam.geo" -format vtk -o "$out/beam_ascii.vtk"
/usr/bin/python3 "$here/vtk_rewrite.py" "$out/beam_ascii.vtk" "$out/beam_binary.vtk" binary 5.1

gmsh -v 1 -2 "$here/capsule.geo" -format stl -o "$out/capsule.stl"
gmsh -v 1 -2 "$here/capsule.geo" -format stl -bin -o "$out/capsule_binary.stl"
