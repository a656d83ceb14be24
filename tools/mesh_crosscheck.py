#!/usr/bin/env python3
"""Leaflet mesher cross-check: our advancing front and spade (from
`cargo bench --bench mesher -- --outlines-dir DIR`) against Triangle
(Shewchuk, PyPI `triangle`) and gmsh (Frontal-Delaunay 2-D, PyPI `gmsh`) on
the very same boundary nodes, h = 0.5 mm.

For every template: time per leaflet (median, and minimum in the summary; CPU time of the process
for Triangle and gmsh, of the meshing thread for ours and spade, so that
other jobs on a shared machine do not count), triangle count, min angle,
mean and min shape quality 4*sqrt(3)*A/sum(l^2), the fraction of edges in
[0.7 h, 1.4 h], text histograms of per-triangle min angle and shape, and the
time ratios ours / peer. All quality numbers are computed here, by one
implementation, for all four meshes.

    tools/mesh_crosscheck.py [--dir DIR] [--no-bench] [--reps N]

--no-bench reuses DIR's JSON files from an earlier bench run. Exit status 1
when a mesher fails or a mesh leaves the boundary nodes out.
"""

import argparse
import glob
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

ANGLE_BINS = [0, 20, 25, 30, 35, 40, 45, 50, 55, 60.0001]
SHAPE_BINS = [0, 0.5, 0.7, 0.8, 0.9, 0.95, 1.0000001]


def metrics(nodes, tris, h):
    p = np.asarray(nodes, float)
    t = np.asarray(tris, int)
    a, b, c = p[t[:, 0]], p[t[:, 1]], p[t[:, 2]]
    area = 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    la, lb, lc = (np.linalg.norm(b - c, axis=1), np.linalg.norm(c - a, axis=1), np.linalg.norm(a - b, axis=1))
    shape = 4 * np.sqrt(3) * area / (la**2 + lb**2 + lc**2)

    def angle(opp, s1, s2):
        return np.degrees(np.arccos(np.clip((s1**2 + s2**2 - opp**2) / (2 * s1 * s2), -1, 1)))

    min_ang = np.minimum(np.minimum(angle(la, lb, lc), angle(lb, lc, la)), angle(lc, la, lb))
    e = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    e = np.unique(e, axis=0)
    el = np.linalg.norm(p[e[:, 0]] - p[e[:, 1]], axis=1)
    return {
        "tris": len(t),
        "min_angle": float(min_ang.min()),
        "mean_shape": float(shape.mean()),
        "min_shape": float(shape.min()),
        "edges_in_band": float(np.mean((el >= 0.7 * h) & (el <= 1.4 * h))),
        "area": float(area.sum()),
        "angle_hist": np.histogram(min_ang, ANGLE_BINS)[0] / len(t),
        "shape_hist": np.histogram(shape, SHAPE_BINS)[0] / len(t),
    }


def soup_to_indexed(soup):
    pts = {}
    tris = []
    for tri in soup:
        ids = []
        for q in tri:
            k = (q[0], q[1])
            ids.append(pts.setdefault(k, len(pts)))
        tris.append(ids)
    nodes = [None] * len(pts)
    for k, i in pts.items():
        nodes[i] = k
    return nodes, tris


def run_triangle(bnd, h, reps):
    import triangle

    n = len(bnd)
    geo = {"vertices": np.asarray(bnd, float), "segments": np.array([[i, (i + 1) % n] for i in range(n)])}
    # q25: min angle 25 deg; a: max area of the equilateral triangle of side h
    # (spade gets the same); Y: no Steiner points on the boundary, so the
    # boundary nodes stay those of our mesher; Q: quiet.
    sw = "pq25a%.9fYQ" % (np.sqrt(3) / 4 * h * h)
    ts = []
    for _ in range(reps):
        t0 = time.process_time()
        out = triangle.triangulate(geo, sw)
        ts.append((time.process_time() - t0) * 1e3)
    return statistics.median(ts), min(ts), out["vertices"].tolist(), out["triangles"].tolist()


def run_gmsh(bnd, h, reps):
    import gmsh

    gmsh.initialize(["-noenv"])
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.model.add("leaflet")
        pts = [gmsh.model.geo.addPoint(x, y, 0, h) for x, y in bnd]
        n = len(pts)
        lines = [gmsh.model.geo.addLine(pts[i], pts[(i + 1) % n]) for i in range(n)]
        loop = gmsh.model.geo.addCurveLoop(lines)
        gmsh.model.geo.addPlaneSurface([loop])
        gmsh.model.geo.synchronize()
        # Keep the boundary nodes: one element per boundary segment.
        for ln in lines:
            gmsh.model.mesh.setTransfiniteCurve(ln, 2)
        gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay
        gmsh.option.setNumber("Mesh.MeshSizeMin", h)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        ts = []
        for _ in range(reps):
            gmsh.model.mesh.clear()
            t0 = time.process_time()
            gmsh.model.mesh.generate(2)
            ts.append((time.process_time() - t0) * 1e3)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        idx = {int(tg): i for i, tg in enumerate(tags)}
        xy = np.asarray(coords).reshape(-1, 3)[:, :2].tolist()
        etypes, _, enodes = gmsh.model.mesh.getElements(2)
        tris = []
        for et, en in zip(etypes, enodes):
            if et == 2:  # 3-node triangle
                tris += [[idx[int(a)], idx[int(b)], idx[int(c)]] for a, b, c in np.asarray(en).reshape(-1, 3)]
        return statistics.median(ts), min(ts), xy, tris
    finally:
        gmsh.finalize()


def hist_lines(name, bins, hists):
    out = [f"  {name:<14}" + "".join(f"{k:>10}" for k in hists)]
    for i in range(len(bins) - 1):
        row = f"  [{bins[i]:.4g}, {bins[i + 1]:.4g})".ljust(16)
        row += "".join(f"{100 * h[i]:>9.1f}%" for h in hists.values())
        out.append(row)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dir", help="where the bench writes the outlines (default: a temporary directory)")
    ap.add_argument("--no-bench", action="store_true", help="reuse DIR's JSON files")
    ap.add_argument("--reps", type=int, default=7, help="timing repetitions for Triangle and gmsh")
    args = ap.parse_args()
    d = args.dir or tempfile.mkdtemp(prefix="mesh-crosscheck-")
    if not args.no_bench:
        repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        r = subprocess.run(["cargo", "bench", "--bench", "mesher", "--", "--outlines-dir", d], cwd=repo)
        if r.returncode != 0:
            print("cargo bench --bench mesher failed", file=sys.stderr)
            return 1
    files = sorted(glob.glob(os.path.join(d, "*.json")))
    if not files:
        print(f"no outline JSON files in {d}", file=sys.stderr)
        return 1
    failed = False
    summary = []
    for f in files:
        doc = json.load(open(f))
        h = doc["h_mm"]
        bnd = doc["boundary_mm"]
        res = {}
        o, sp = doc["ours"], doc["spade"]
        # Older bench output has no minimum: fall back to the median.
        res["ours"] = (o["ms"], o.get("min_ms", o["ms"]), o["nodes_mm"], o["tris"])
        sn, st = soup_to_indexed(sp["tris_mm"])
        res["spade"] = (sp["ms"], sp.get("min_ms", sp["ms"]), sn, st)
        for name, fn in (("triangle", run_triangle), ("gmsh", run_gmsh)):
            try:
                res[name] = fn(bnd, h, args.reps)
            except Exception as e:  # a peer failing is reported, not fatal to the others
                print(f"{name} failed on {doc['template']}: {e}", file=sys.stderr)
                failed = True
        print(f"\n{doc['template']}  (h = {h} mm, {len(bnd)} boundary nodes)")
        print(f"  {'mesher':<10}{'ms':>9}{'tris':>8}{'minang':>8}{'mean q':>8}{'min q':>8}{'band':>8}{'area':>10}{'ours/x':>8}")
        m = {}
        b0 = {tuple(p) for p in np.round(np.asarray(bnd), 9).tolist()}
        for name, (ms, _, nodes, tris) in res.items():
            m[name] = metrics(nodes, tris, h)
            have = {tuple(p) for p in np.round(np.asarray(nodes, float), 9).tolist()}
            if not b0 <= have:
                print(f"  {name}: {len(b0 - have)} boundary nodes missing", file=sys.stderr)
                failed = True
            q = m[name]
            print(
                f"  {name:<10}{ms:>9.2f}{q['tris']:>8}{q['min_angle']:>8.1f}{q['mean_shape']:>8.3f}"
                f"{q['min_shape']:>8.3f}{100 * q['edges_in_band']:>7.1f}%{q['area']:>10.3f}"
                f"{res['ours'][0] / ms:>8.2f}"
            )
        summary.append((doc["template"], {k: v[0] for k, v in res.items()}, {k: v[1] for k, v in res.items()}, m["ours"]))
        print("  min angle per triangle (deg), share of triangles:")
        print("\n".join(hist_lines("bin", ANGLE_BINS, {k: v["angle_hist"] for k, v in m.items()})))
        print("  shape quality per triangle, share of triangles:")
        print("\n".join(hist_lines("bin", SHAPE_BINS, {k: v["shape_hist"] for k, v in m.items()})))
    names = ["ours", "spade", "triangle", "gmsh"]
    for label, k in (("median", 1), ("minimum", 2)):
        print(f"\nsummary: {label} CPU ms per leaflet and ours / peer")
        print(f"  {'template':<36}" + "".join(f"{n:>10}" for n in names) + "".join(f"{'/' + n:>10}" for n in names[1:])
              + f"{'minang':>8}{'mean q':>8}{'band':>7}")
        for row_ in summary:
            name, ms, q = row_[0], row_[k], row_[3]
            row = f"  {name[:36]:<36}" + "".join(f"{ms[n]:>10.2f}" if n in ms else f"{'-':>10}" for n in names)
            row += "".join(f"{ms['ours'] / ms[n]:>10.2f}" if n in ms else f"{'-':>10}" for n in names[1:])
            row += f"{q['min_angle']:>8.1f}{q['mean_shape']:>8.3f}{100 * q['edges_in_band']:>6.1f}%"
            print(row)
        worst = max(r[k]["ours"] for r in summary)
        print(f"  slowest leaflet, ours ({label}): {worst:.2f} ms (target <= 20 ms)")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
