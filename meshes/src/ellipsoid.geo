// Ellipsoid with semi-axes 1.5 x 1.0 x 0.8 (an organ-sized blob in decimetres).
SetFactory("OpenCASCADE");
Sphere(1) = {0, 0, 0, 1};
Dilate {{0, 0, 0}, {1.5, 1.0, 0.8}} { Volume{1}; }
Mesh.MeshSizeMax = 0.25;
Mesh.MeshSizeFromCurvature = 0;
// Model units are decimetres; the mesh is written in metres (tissue_cut works in SI units).
Mesh.ScalingFactor = 0.1;
