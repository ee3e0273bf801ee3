// Capsule: cylinder of radius 0.5 and length 2 along x with hemispherical caps (closed surface).
SetFactory("OpenCASCADE");
Cylinder(1) = {0, 0, 0, 2, 0, 0, 0.5};
Sphere(2) = {0, 0, 0, 0.5};
Sphere(3) = {2, 0, 0, 0.5};
BooleanUnion(4) = {Volume{1}; Delete;}{Volume{2, 3}; Delete;};
Mesh.MeshSizeMax = 0.2;
// Model units are decimetres; the mesh is written in metres (tissue_cut works in SI units).
Mesh.ScalingFactor = 0.1;
