// Surface of small_sphere.geo, for TetGen.
SetFactory("OpenCASCADE");
Sphere(1) = {0, 0, 0, 1};
Mesh.MeshSizeMax = 0.5;
Mesh.MeshSizeFromCurvature = 0;
