#!/usr/bin/env python3
"""Distance of each detected landmark to a reference file, per point.

    tools/.venv/bin/python tools/landmark_distances.py TRUTH.mrk.json FOUND.mrk.json

Reads two 3D Slicer markups files (LPS) holding C1-C3 and N1-N3 and prints,
per point, the distance (mm) and its parts in the truth's commissure frame:
height along the commissure plane's normal, angle about the commissures'
centroid, radius. A user's file may number its sinuses from another one
(`../shared/real/landmarks.mrk.json` starts at the posterior sinus), so the
labels are matched by the cyclic shift that makes the summed distance
smallest; the shift is printed. Exit 2 on a file that lacks a point.
"""

import json
import sys

import numpy as np

LABELS = ["C1", "C2", "C3", "N1", "N2", "N3"]


def points(path):
    with open(path) as f:
        doc = json.load(f)
    out = {}
    for markup in doc.get("markups", []):
        for cp in markup.get("controlPoints", []):
            out[cp["label"]] = np.array(cp["position"], dtype=float)
    missing = [k for k in LABELS if k not in out]
    if missing:
        sys.exit(f"{path}: no point labelled {', '.join(missing)}")
    return out


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    truth, found = points(sys.argv[1]), points(sys.argv[2])
    comm = np.array([truth[f"C{i}"] for i in (1, 2, 3)])
    nadir = np.array([truth[f"N{i}"] for i in (1, 2, 3)])
    c0 = comm.mean(axis=0)
    n = np.cross(comm[1] - comm[0], comm[2] - comm[0])
    n /= np.linalg.norm(n)
    if np.dot(c0 - nadir.mean(axis=0), n) < 0:
        n = -n
    e1 = comm[0] - c0
    e1 -= n * np.dot(e1, n)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)

    def angle(v):
        return np.degrees(np.arctan2(np.dot(v, e2), np.dot(v, e1)))

    def radius(v):
        return np.linalg.norm(v - n * np.dot(v, n))

    best = None
    for shift in range(3):
        m = {f"{p}{i}": f"{p}{(i - 1 + shift) % 3 + 1}" for p in "CN" for i in (1, 2, 3)}
        total = sum(np.linalg.norm(truth[k] - found[m[k]]) for k in LABELS)
        if best is None or total < best[0]:
            best = (total, shift, m)
    _, shift, m = best
    if shift:
        print(f"labels matched with a cyclic shift of {shift} (truth C1 = found {m['C1']})")
    print("point  dist_mm  d_height_mm  d_angle_deg  d_radius_mm")
    for k in LABELS:
        a, b = truth[k] - c0, found[m[k]] - c0
        dang = (angle(b) - angle(a) + 180.0) % 360.0 - 180.0
        print(
            f"{k:5s}  {np.linalg.norm(a - b):7.2f}  {np.dot(b - a, n):11.2f}"
            f"  {dang:11.1f}  {radius(b) - radius(a):11.2f}"
        )


if __name__ == "__main__":
    main()
