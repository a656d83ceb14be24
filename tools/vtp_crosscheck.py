#!/usr/bin/env python3
"""Read a coapt-written .vtp (or .stl / .ply) with VTK's own reader and report
what VTK sees. Exit status 1 if VTK reported an error or warning, or if the
file disagrees with --expect-json.

    tools/.venv/bin/python tools/vtp_crosscheck.py FILE.vtp [--expect-json J]

J (a file or an inline JSON object) may hold: points, cells, polys, lines,
frame, point_arrays / cell_arrays / field_arrays ({name: [VTK type, components]}),
points_flat (x y z ...), polys_flat (i j k ...), and values ({"point:NAME" |
"cell:NAME" | "field:NAME": [flat values or strings]}) compared exactly.
"""
import argparse
import json
import sys
from pathlib import Path

import vtk


class Errors:
    """Collects ErrorEvent/WarningEvent from the reader and VTK's output window."""

    def __init__(self):
        self.messages = []
        self.window = vtk.vtkStringOutputWindow()
        vtk.vtkOutputWindow.SetInstance(self.window)

    def watch(self, obj):
        for ev in ("ErrorEvent", "WarningEvent"):
            obj.AddObserver(ev, lambda o, e, ev=ev: self.messages.append(f"{ev} from {o.GetClassName()}"))

    def all(self):
        text = self.window.GetOutput().strip()
        return self.messages + ([text] if text else [])


def vtk_type_name(arr):
    if arr.IsA("vtkStringArray"):
        return "String"
    names = {
        vtk.VTK_FLOAT: "Float32", vtk.VTK_DOUBLE: "Float64",
        vtk.VTK_CHAR: "Int8", vtk.VTK_SIGNED_CHAR: "Int8", vtk.VTK_UNSIGNED_CHAR: "UInt8",
        vtk.VTK_SHORT: "Int16", vtk.VTK_UNSIGNED_SHORT: "UInt16",
        vtk.VTK_INT: "Int32", vtk.VTK_UNSIGNED_INT: "UInt32",
        vtk.VTK_LONG_LONG: "Int64", vtk.VTK_UNSIGNED_LONG_LONG: "UInt64",
        vtk.VTK_ID_TYPE: "Int64",
    }
    t = arr.GetDataType()
    if t == vtk.VTK_LONG:
        return "Int64" if arr.GetDataTypeSize() == 8 else "Int32"
    return names.get(t, arr.GetDataTypeAsString())


def arrays(fd):
    out = {}
    for i in range(fd.GetNumberOfArrays()):
        a = fd.GetAbstractArray(i)
        out[a.GetName()] = [vtk_type_name(a), a.GetNumberOfComponents(), a.GetNumberOfTuples()]
    return out


def read(path, errors):
    ext = path.suffix.lower()
    reader = {".vtp": vtk.vtkXMLPolyDataReader, ".stl": vtk.vtkSTLReader, ".ply": vtk.vtkPLYReader}[ext]()
    errors.watch(reader)
    reader.SetFileName(str(path))
    reader.Update()
    return reader, reader.GetOutput()


def report(path, reader, pd):
    frame = None
    fa = pd.GetFieldData().GetAbstractArray("frame")
    if fa is not None and fa.IsA("vtkStringArray") and fa.GetNumberOfValues() > 0:
        frame = fa.GetValue(0)
    info = {
        "file": str(path),
        "points": pd.GetNumberOfPoints(),
        "cells": pd.GetNumberOfCells(),
        "polys": pd.GetNumberOfPolys(),
        "lines": pd.GetNumberOfLines(),
        "verts": pd.GetNumberOfVerts(),
        "strips": pd.GetNumberOfStrips(),
        "frame": frame,
        "bounds": list(pd.GetBounds()) if pd.GetNumberOfPoints() else None,
        "point_arrays": arrays(pd.GetPointData()),
        "cell_arrays": arrays(pd.GetCellData()),
        "field_arrays": arrays(pd.GetFieldData()),
    }
    if pd.GetPoints() is not None:
        info["points_type"] = vtk_type_name(pd.GetPoints().GetData())
    if path.suffix.lower() == ".ply":
        info["ply_comments"] = [reader.GetComments().GetValue(i) for i in range(reader.GetComments().GetNumberOfValues())] \
            if hasattr(reader, "GetComments") else None
    return info


def flat_values(arr):
    if arr.IsA("vtkStringArray"):
        return [arr.GetValue(i) for i in range(arr.GetNumberOfValues())]
    return [arr.GetValue(i) for i in range(arr.GetNumberOfValues())]


def polys_flat(pd):
    ids, out = vtk.vtkIdList(), []
    polys = pd.GetPolys()
    polys.InitTraversal()
    while polys.GetNextCell(ids):
        out += [ids.GetId(k) for k in range(ids.GetNumberOfIds())]
    return out


def compare_values(pd, expect):
    problems = []
    if "points_flat" in expect:
        got = [c for i in range(pd.GetNumberOfPoints()) for c in pd.GetPoint(i)]
        if got != expect["points_flat"]:
            problems.append("point coordinates differ from the expected values")
    if "polys_flat" in expect and polys_flat(pd) != expect["polys_flat"]:
        problems.append("triangle connectivity differs from the expected values")
    where = {"point": pd.GetPointData(), "cell": pd.GetCellData(), "field": pd.GetFieldData()}
    for key, want in expect.get("values", {}).items():
        kind, name = key.split(":", 1)
        arr = where[kind].GetAbstractArray(name)
        if arr is None:
            problems.append(f"{key}: missing")
        elif flat_values(arr) != want:
            problems.append(f"{key}: VTK read {flat_values(arr)[:8]}..., expected {want[:8]}...")
    return problems


def compare(info, expect):
    problems = []
    for key in ("points", "cells", "polys", "lines", "frame"):
        if key in expect and info[key] != expect[key]:
            problems.append(f"{key}: VTK read {info[key]!r}, expected {expect[key]!r}")
    for key in ("point_arrays", "cell_arrays", "field_arrays"):
        for name, (ty, comps) in expect.get(key, {}).items():
            got = info[key].get(name)
            if got is None:
                problems.append(f"{key}: '{name}' missing")
            elif got[:2] != [ty, comps]:
                problems.append(f"{key}: '{name}' is {got[:2]}, expected {[ty, comps]}")
    return problems


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("file", type=Path)
    ap.add_argument("--expect-json", help="JSON file or inline JSON object with expected values")
    args = ap.parse_args()
    errors = Errors()
    reader, pd = read(args.file, errors)
    info = report(args.file, reader, pd)
    problems = [f"VTK reported: {m}" for m in errors.all()]
    if args.expect_json:
        text = args.expect_json
        expect = json.loads(text if text.lstrip().startswith("{") else Path(text).read_text())
        problems += compare(info, expect) + compare_values(pd, expect)
        info["checked_values"] = sorted(k for k in ("points_flat", "polys_flat") if k in expect) + sorted(
            expect.get("values", {}))
    info["vtk_version"] = vtk.vtkVersion.GetVTKVersion()
    info["problems"] = problems
    print("{\n" + ",\n".join(f" {json.dumps(k)}: {json.dumps(v)}" for k, v in info.items()) + "\n}")
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()
