// 2 x 1 x 1 block with a cylindrical through-hole of radius 0.25 along y.
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 2, 1, 1};
Cylinder(2) = {1, -0.1, 0.5, 0, 1.2, 0, 0.25};
BooleanDifference(3) = {Volume{1}; Delete;}{Volume{2}; Delete;};
Physical Volume("tissue", 1) = {3};
Mesh.MeshSizeMax = 0.13;
// Model units are decimetres; the mesh is written in metres (tissue_cut works in SI units).
Mesh.ScalingFactor = 0.1;
