// Unit sphere, coarse: the base of the format variants and of the bad files.
SetFactory("OpenCASCADE");
Sphere(1) = {0, 0, 0, 1};
Mesh.MeshSizeMax = 0.5;
Mesh.MeshSizeFromCurvature = 0;
