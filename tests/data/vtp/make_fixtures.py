#!/usr/bin/env python3
"""Write the VTK-compatibility fixtures read by `crates/io/src/vtp` tests.

One small mesh (a vertex cell, a polyline, three triangles, point, cell and
field data including string arrays) saved by vtkXMLPolyDataWriter in every
mode VTK offers. Regenerate with:

    tools/.venv/bin/python tests/data/vtp/make_fixtures.py tests/data/vtp
"""
import sys
from pathlib import Path

import vtk


def mesh(points_type="double"):
    pd = vtk.vtkPolyData()
    pts = vtk.vtkPoints()
    if points_type == "double":
        pts.SetDataTypeToDouble()
    else:
        pts.SetDataTypeToFloat()
    for p in [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, 1.0, 0.0), (0.0, 1.0, 0.1),
              (-1.0 / 3.0, 0.5, 1e-300), (2.5, -7.25, 1e10)]:
        pts.InsertNextPoint(p)
    pd.SetPoints(pts)
    verts = vtk.vtkCellArray()
    verts.InsertNextCell(1, [5])
    lines = vtk.vtkCellArray()
    lines.InsertNextCell(3, [0, 1, 2])
    polys = vtk.vtkCellArray()
    for t in [(0, 1, 2), (0, 2, 3), (0, 3, 4)]:
        polys.InsertNextCell(3, t)
    pd.SetVerts(verts)
    pd.SetLines(lines)
    pd.SetPolys(polys)

    def arr(cls, name, comps, values):
        a = cls()
        a.SetName(name)
        a.SetNumberOfComponents(comps)
        for v in values:
            a.InsertNextValue(v)
        return a

    n = 6
    pd.GetPointData().AddArray(arr(vtk.vtkFloatArray, "temperature", 1, [0.5 * i + 0.25 for i in range(n)]))
    pd.GetPointData().AddArray(arr(vtk.vtkDoubleArray, "disp", 3, [i / 7.0 for i in range(3 * n)]))
    pd.GetPointData().AddArray(arr(vtk.vtkIntArray, "label", 1, [-3, -2, -1, 0, 1, 2]))
    pd.GetPointData().AddArray(arr(vtk.vtkUnsignedCharArray, "flag", 1, [0, 1, 2, 250, 255, 7]))
    pd.GetPointData().AddArray(arr(vtk.vtkShortArray, "short", 1, [-300, 0, 1, 2, 3, 300]))
    pd.GetPointData().AddArray(arr(vtk.vtkTypeInt64Array, "big", 1, [-(2**40), 0, 1, 2, 3, 2**40]))
    # Cell order: 1 vertex, 1 line, 3 triangles.
    pd.GetCellData().AddArray(arr(vtk.vtkIntArray, "cellid", 1, [100, 101, 102, 103, 104]))
    pd.GetCellData().AddArray(arr(vtk.vtkDoubleArray, "quality", 1, [0.0, 0.1, 0.2, 0.3, 0.4]))
    fd = pd.GetFieldData()
    frame = vtk.vtkStringArray()
    frame.SetName("frame")
    frame.InsertNextValue("LPS")
    fd.AddArray(frame)
    notes = vtk.vtkStringArray()
    notes.SetName("notes")
    notes.InsertNextValue("hello world")
    notes.InsertNextValue("second")
    notes.InsertNextValue("é µ")  # ascii mode writes these bytes as negative chars
    fd.AddArray(notes)
    fd.AddArray(arr(vtk.vtkDoubleArray, "scale", 1, [2.5, -0.125]))
    return pd


def write(pd, path, mode, header64=False, compress=False, big=False, encode=True, block=None):
    w = vtk.vtkXMLPolyDataWriter()
    w.SetFileName(str(path))
    w.SetInputData(pd)
    {"ascii": w.SetDataModeToAscii, "binary": w.SetDataModeToBinary,
     "appended": w.SetDataModeToAppended}[mode]()
    w.SetEncodeAppendedData(1 if encode else 0)
    if header64:
        w.SetHeaderTypeToUInt64()
    else:
        w.SetHeaderTypeToUInt32()
    if compress:
        w.SetCompressorTypeToZLib()
    else:
        w.SetCompressorTypeToNone()
    if block:
        w.SetBlockSize(block)
    if big:
        w.SetByteOrderToBigEndian()
    else:
        w.SetByteOrderToLittleEndian()
    assert w.Write() == 1, path


def main():
    out = Path(sys.argv[1] if len(sys.argv) > 1 else ".")
    out.mkdir(parents=True, exist_ok=True)
    pd = mesh()
    write(pd, out / "ascii.vtp", "ascii")
    write(pd, out / "binary_u32.vtp", "binary")
    write(pd, out / "binary_u64.vtp", "binary", header64=True)
    write(pd, out / "binary_zlib_u32.vtp", "binary", compress=True)
    write(pd, out / "appended_raw_u64.vtp", "appended", header64=True, encode=False)
    write(pd, out / "appended_raw_u32.vtp", "appended", encode=False)
    write(pd, out / "appended_base64_u32.vtp", "appended")
    write(pd, out / "appended_base64_zlib_u64.vtp", "appended", header64=True, compress=True)
    write(pd, out / "appended_raw_zlib_u64.vtp", "appended", header64=True, compress=True, encode=False)
    # Tiny blocks so every array spans several compressed blocks.
    write(pd, out / "appended_raw_zlib_blocks.vtp", "appended", compress=True, encode=False, block=16)
    write(pd, out / "binary_zlib_blocks.vtp", "binary", compress=True, block=16)
    write(pd, out / "bigendian_raw.vtp", "appended", big=True, encode=False)
    write(pd, out / "bigendian_zlib_u64.vtp", "appended", big=True, header64=True, compress=True, encode=False)
    write(pd, out / "bigendian_binary.vtp", "binary", big=True)
    # 3D Slicer's usual output: Float32 points, zlib, appended raw.
    write(mesh("float"), out / "points_float32_zlib.vtp", "appended", header64=True, compress=True, encode=False)
    print("VTK", vtk.vtkVersion.GetVTKVersion(), "wrote fixtures to", out)


if __name__ == "__main__":
    main()
