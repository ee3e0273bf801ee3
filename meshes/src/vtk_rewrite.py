"""Rewrites a VTK legacy unstructured grid with VTK itself: ascii|binary, file version 4.2|5.1.

usage: /usr/bin/python3 vtk_rewrite.py in.vtk out.vtk ascii|binary 4.2|5.1
Version 4.2 has the classic CELLS layout, 5.1 the OFFSETS/CONNECTIVITY one.
"""
import sys

import vtk


def main(source, target, encoding, version):
    reader = vtk.vtkUnstructuredGridReader()
    reader.SetFileName(source)
    reader.Update()
    grid = reader.GetOutput()
    if grid.GetNumberOfCells() == 0:
        sys.exit(f"{source}: VTK read no cells")
    writer = vtk.vtkUnstructuredGridWriter()
    writer.SetFileName(target)
    writer.SetInputData(grid)
    if encoding == "binary":
        writer.SetFileTypeToBinary()
    else:
        writer.SetFileTypeToASCII()
    writer.SetFileVersion({"4.2": 42, "5.1": 51}[version])
    if not writer.Write():
        sys.exit(f"{target}: VTK could not write")


if __name__ == "__main__":
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    main(*sys.argv[1:])
