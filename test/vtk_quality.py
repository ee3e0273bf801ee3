#!/usr/bin/python3
"""Prints the tets' quality as VTK computes it (vtkMeshQuality, radius ratio, reported as
Q = 3 r_in / R_circ = 1 / radius ratio): 'count min mean'. An independent check of the
statistics cut_replay reports. usage: vtk_quality.py MESH.vtk"""
import sys
import vtk
from vtk.util.numpy_support import vtk_to_numpy

reader = vtk.vtkUnstructuredGridReader()
reader.SetFileName(sys.argv[1])
reader.Update()
grid = reader.GetOutput()
quality = vtk.vtkMeshQuality()
quality.SetInputData(grid)
quality.SetTetQualityMeasureToRadiusRatio()
quality.Update()
rr = vtk_to_numpy(quality.GetOutput().GetCellData().GetArray('Quality'))
q = [1.0 / r if r > 0 else 0.0 for r in rr]
print(len(q), '%.17g' % min(q), '%.17g' % (sum(q) / len(q)))
