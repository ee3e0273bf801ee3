#!/bin/sh
# Regenerates test/data/ (format variants of a small sphere, 10-node tets, hand-made cubes) and
# test/data/bad/. Needs gmsh (4.8), tetgen (1.5) and /usr/bin/python3 with the vtk module.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
data=$(dirname "$here")
rewrite="$here/../../../meshes/src/vtk_rewrite.py"
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

sphere="$here/small_sphere.geo"
gmsh -v 1 -3 "$sphere" -format msh22 -o "$data/sphere_v22.msh"
gmsh -v 1 -3 "$sphere" -format msh22 -bin -o "$data/sphere_v22_binary.msh"
gmsh -v 1 -3 "$sphere" -format msh41 -o "$data/sphere_v41.msh"
gmsh -v 1 -3 "$sphere" -format msh41 -bin -o "$data/sphere_v41_binary.msh"
gmsh -v 1 -3 "$sphere" -format vtk -o "$data/sphere_ascii.vtk"
/usr/bin/python3 "$rewrite" "$data/sphere_ascii.vtk" "$data/sphere_v42_binary.vtk" binary 4.2
/usr/bin/python3 "$rewrite" "$data/sphere_ascii.vtk" "$data/sphere_v51_ascii.vtk" ascii 5.1
# The same mesh with 10-node tets: same corners, so the same volume once midside nodes are gone.
gmsh -v 1 -3 -order 2 "$sphere" -format msh22 -o "$data/sphere_tet10_v22.msh"
gmsh -v 1 -3 -order 2 "$sphere" -format msh41 -o "$data/sphere_tet10_v41.msh"
gmsh -v 1 -3 -order 2 "$sphere" -format vtk -o "$data/sphere_tet10.vtk"

gmsh -v 1 -2 "$here/small_sphere_surface.geo" -format stl -o "$scratch/sphere.stl"
# Both runs write sphere.1.*; -o2 adds midside nodes to the same tets.
(cd "$scratch" && tetgen -pqQ sphere.stl >/dev/null)
cp "$scratch/sphere.1.node" "$data/sphere_tetgen.node"
cp "$scratch/sphere.1.ele" "$data/sphere_tetgen.ele"
(cd "$scratch" && rm -f sphere.1.* && tetgen -pqo2Q sphere.stl >/dev/null)
cp "$scratch/sphere.1.node" "$data/sphere_tet10_tetgen.node"
cp "$scratch/sphere.1.ele" "$data/sphere_tet10_tetgen.ele"

/usr/bin/python3 "$here/make_test_data.py" "$data"
