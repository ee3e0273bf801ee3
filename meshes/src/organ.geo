// Ellipsoid organ (semi-axes 15 x 10 x 8 cm), surface only: TetGen fills it (make_organ.py).
// h: surface element size in decimetres, set with -setnumber h VALUE.
SetFactory("OpenCASCADE");
DefineConstant[ h = {0.15, Name "h"} ];
Sphere(1) = {0, 0, 0, 1};
Dilate {{0, 0, 0}, {1.5, 1.0, 0.8}} { Volume{1}; }
Mesh.MeshSizeMax = h;
Mesh.MeshSizeMin = h;
Mesh.MeshSizeFromCurvature = 0;
// Model units are decimetres; the mesh is written in metres (tissue_cut works in SI units).
Mesh.ScalingFactor = 0.1;
