// Surface of a unit sphere, tetrahedralised by TetGen in make_meshes.sh.
SetFactory("OpenCASCADE");
Sphere(1) = {0, 0, 0, 1};
Mesh.MeshSizeMax = 0.25;
// Model units are decimetres; the mesh is written in metres (tissue_cut works in SI units).
Mesh.ScalingFactor = 0.1;
