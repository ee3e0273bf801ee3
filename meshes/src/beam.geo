// 4 x 1 x 1 beam.
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 4, 1, 1};
Mesh.MeshSizeMax = 0.22;
// Model units are decimetres; the mesh is written in metres (tissue_cut works in SI units).
Mesh.ScalingFactor = 0.1;
