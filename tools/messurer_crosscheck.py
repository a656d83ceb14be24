#!/usr/bin/env python3
"""The seeds' group's coaptation measures on coapt's closed peer leaflet.

    coapt bench close --case ozaki-cylinder --h 0.5 --bending --threads 1 \
        --dump DIR --csv DIR/bench.csv
    python3 tools/messurer_crosscheck.py DIR/closed_h0.5.csv DIR/bench.csv

Re-implements, from reading (no code copied), the measures that
23Grammer58/membrane_model computes for its one-leaflet sewing benchmark
(benchmarks/Sewing/TestVirtualSuturer.cpp `run_suture_simulation` with
AVSim/AorticSimulator/Messurer.cpp) and applies them to the closed leaflet
that `bench close --dump` writes (nodes: reference and closed position,
boundary 1 sutured / 2 free, plane distances d0 d1; triangles beside it).
Frame: the bench's, axis +z through the origin, commissures at z = 0.

Their one-leaflet rules, as read:
  * the other two cusps are moved 2R away, so the leaflet "collides" only
    with the two planes through the dilation point C (the circumcentre of
    the commissures, on the axis) and a commissure; a point is labelled for
    a plane when its signed distance from it is below 0.5 x thickness
    (`setMargin(0.5*Ht)`, 0.25 mm), penetration included;
  * triangles with a labelled vertex and no label common to all three
    vertices are split in four, 4 times (`computeCollidingBnd(4)`);
  * coaptation_area = area of the refined triangles whose three vertices
    all carry a label (`computeColArea().colArea`, both planes, mm^2);
  * length_coaptation = per plane, the labelled edges projected on the plane
    (x radial, y axial), 501 columns across their x range, the largest
    up - down; the larger plane (`getCoaptH`, mm);
  * central_coaptation = axial extent of the vertices labelled for both
    planes (`computeHc`, mm); form_closed_valve = such vertices exist;
  * billowing = distance of the lowest node (along the axis) from the plane
    through the three cusps' lowest fixed nodes (`computeBillowing`, mm);
  * effective_height = distance of the free edge's centre (their template's
    node labelled 1|4) from that plane (mm);
  * closure_degree = smallest distance of a node from C across the axis (mm).

coapt's own values: coaptation height and area from the bench CSV (the zone
within eta2 = 0.01 R of a plane, distance interpolated over each triangle;
this script recomputes both from the dump and stops with exit 1 if they
disagree); central coaptation, effective height and billowing by the
report stage's definitions (docs/report.md) applied to the
bench zone rule, since `bench close` does not print them.

Exit 0 after printing; 1 if the recomputed bench values disagree; 2 on bad
input (file and problem named).
"""

import argparse
import csv
import math
import sys

import numpy as np

COLUMNS = ["i", "x0", "y0", "z0", "x", "y", "z", "boundary", "contact", "d0", "d1"]


def fail(path, problem):
    print(f"messurer_crosscheck: {path}: {problem}", file=sys.stderr)
    sys.exit(2)


def read_nodes(path):
    try:
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
    except OSError as e:
        fail(path, f"cannot read: {e.strerror}")
    if not rows or rows[0] != COLUMNS:
        fail(path, f"header must be {','.join(COLUMNS)} (bench close --dump)")
    try:
        a = np.array([[float(v) for v in r] for r in rows[1:]], dtype=float)
    except ValueError as e:
        fail(path, f"non-numeric value: {e}")
    if a.ndim != 2 or a.shape[1] != len(COLUMNS) or len(a) < 3:
        fail(path, "needs at least 3 nodes of 11 columns")
    if not np.all(np.isfinite(a)):
        fail(path, "non-finite value")
    if not np.array_equal(a[:, 0], np.arange(len(a))):
        fail(path, "node ids must be 0, 1, 2, ... in order")
    return a


def read_tris(path, n):
    try:
        with open(path, newline="") as f:
            rows = [r for r in csv.reader(f) if r]
    except OSError as e:
        fail(path, f"cannot read: {e.strerror}")
    try:
        t = np.array([[int(v) for v in r] for r in rows], dtype=np.int64)
    except ValueError as e:
        fail(path, f"non-integer index: {e}")
    if t.ndim != 2 or t.shape[1] != 3 or len(t) == 0:
        fail(path, "needs rows of three node indices")
    if t.min() < 0 or t.max() >= n:
        fail(path, f"node index outside 0..{n - 1}")
    return t


def read_bench(path):
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        fail(path, f"cannot read: {e.strerror}")
    need = ["h_mm", "converged", "wall_s", "contact_area_mm2", "coaptation_height_mm", "lowest_mm"]
    if len(rows) != 1 or any(k not in rows[0] for k in need):
        fail(path, f"expected one row of `bench close --csv` with {', '.join(need)}")
    r = rows[0]
    if r["converged"] != "true":
        fail(path, "the bench closure did not converge: nothing to measure")
    try:
        return {k: float(r[k]) for k in need if k != "converged"}
    except ValueError as e:
        fail(path, f"non-numeric value: {e}")


# ---------------------------------------------------------------- frame


def their_planes(x_ref, boundary):
    """Unit normals n_k of their two planes, pointing away from the leaflet.

    Their commissures sit in the middle of the gaps between equal leaflets
    (`getCommissurePoints`), i.e. 60 degrees either side of the leaflet's
    middle; the middle is taken from the sutured nodes' angular span."""
    sut = x_ref[boundary == 1]
    mid_dir = sut[:, :2].mean(axis=0)
    mid = math.atan2(mid_dir[1], mid_dir[0])
    da = np.angle(np.exp(1j * (np.arctan2(sut[:, 1], sut[:, 0]) - mid)))
    centre = mid + 0.5 * (da.min() + da.max())
    normals = []
    for side in (-1.0, 1.0):
        a = centre + side * math.pi / 3.0
        u = np.array([math.cos(a), math.sin(a), 0.0])
        n = np.cross([0.0, 0.0, 1.0], u)
        # Away from the leaflet: the leaflet's middle has n . m < 0.
        m = np.array([math.cos(centre), math.sin(centre), 0.0])
        if n @ m > 0:
            n = -n
        normals.append(n)
    return np.array(normals), centre


def signed(p, normals):
    """Distance on the leaflet's side of each plane (planes through the axis)."""
    return -(p @ normals.T)


# ------------------------------------------------------- their measures


def refine(p, normals, margin, levels=4):
    """Their partial-triangle refinement: (triangles (m,3,3), labels (m,3,2))."""
    done_p, done_l = [], []
    for level in range(levels + 1):
        lab = signed(p, normals) < margin  # (m,3,2)
        some = lab.any(axis=(1, 2))
        common = lab.all(axis=1).any(axis=1)
        partial = some & ~common
        if level == levels:
            partial[:] = False
        done_p.append(p[~partial])
        done_l.append(lab[~partial])
        q = p[partial]
        if len(q) == 0:
            break
        a, b, c = q[:, 0], q[:, 1], q[:, 2]
        ab, bc, ca = (a + b) / 2, (b + c) / 2, (c + a) / 2
        p = np.concatenate(
            [
                np.stack([a, ab, ca], 1),
                np.stack([b, bc, ab], 1),
                np.stack([c, ca, bc], 1),
                np.stack([ab, bc, ca], 1),
            ]
        )
    return np.concatenate(done_p), np.concatenate(done_l)


def tri_area(p):
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def column_height(p, lab, n, columns=500):
    """Largest axial thickness of the labelled edges over `columns`+1 radial
    samples (their CoaptScan::computeCoaptDistribution, max of up - down)."""
    e1 = np.cross(n, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    segs = []
    for i, j in ((0, 1), (1, 2), (2, 0)):
        both = lab[:, i] & lab[:, j]
        segs.append(np.stack([p[both, i], p[both, j]], 1))
    s = np.concatenate(segs)
    if len(s) == 0:
        return 0.0
    x = s @ e1
    y = s[:, :, 2]
    lo, hi = x.min(), x.max()
    width = hi - lo
    if width <= 0:
        return 0.0
    hi -= np.finfo(float).eps * width
    lo += np.finfo(float).eps * width
    order = x[:, 0] > x[:, 1]
    x[order] = x[order][:, ::-1]
    y[order] = y[order][:, ::-1]
    # Edges parallel to the axis: their code divides 0 by 0 there (NaN,
    # ignored); such an edge adds nothing a neighbour does not.
    keep = x[:, 1] > x[:, 0]
    x, y = x[keep], y[keep]
    kl = np.ceil((x[:, 0] - lo) / (hi - lo) * columns).astype(np.int64)
    kr = np.floor((x[:, 1] - lo) / (hi - lo) * columns).astype(np.int64)
    kl = np.clip(kl, 0, columns)
    kr = np.clip(kr, -1, columns)
    count = np.maximum(kr - kl + 1, 0)
    idx = np.repeat(np.arange(len(x)), count)
    start = np.repeat(np.cumsum(count) - count, count)
    k = kl[idx] + (np.arange(count.sum()) - start)
    w = (lo + k * (hi - lo) / columns - x[idx, 0]) / (x[idx, 1] - x[idx, 0])
    yy = (1 - w) * y[idx, 0] + w * y[idx, 1]
    up = np.full(columns + 1, -np.inf)
    down = np.full(columns + 1, np.inf)
    np.maximum.at(up, k, yy)
    np.minimum.at(down, k, yy)
    ok = up >= down
    return float((up[ok] - down[ok]).max()) if ok.any() else 0.0


def their_measures(p_tri, normals, margin):
    p, lab = refine(p_tri, normals, margin)
    area = tri_area(p)
    any_lab = lab.any(axis=2)
    coapt = any_lab.all(axis=1)
    both_v = lab.all(axis=2)
    zc = p[both_v][:, 2]
    return {
        "area": float(area[coapt].sum()),
        "area_per_plane": [float(area[lab[:, :, k].all(axis=1)].sum()) for k in (0, 1)],
        "length": max(column_height(p, lab[:, :, k], normals[k]) for k in (0, 1)),
        "length_per_plane": [column_height(p, lab[:, :, k], normals[k]) for k in (0, 1)],
        "central": float(zc.max() - zc.min()) if len(zc) else 0.0,
        "closed": bool(len(zc)),
        "triangles": len(p),
    }


# -------------------------------------------------------- coapt's rules


def clip(poly_p, poly_v, tau, j):
    """Sutherland-Hodgman: keep the part of a polygon where v[j] <= tau."""
    out_p, out_v = [], []
    n = len(poly_p)
    for a in range(n):
        b = (a + 1) % n
        va, vb = poly_v[a], poly_v[b]
        if va[j] <= tau:
            out_p.append(poly_p[a])
            out_v.append(va)
        if (va[j] <= tau) != (vb[j] <= tau):
            s = (tau - va[j]) / (vb[j] - va[j])
            out_p.append(poly_p[a] + (poly_p[b] - poly_p[a]) * s)
            out_v.append(va + (vb - va) * s)
    return out_p, out_v


def coapt_zone(p_tri, normals, tau, planes):
    """The bench's zone rule: each triangle cut where the linearly
    interpolated distance to every plane in `planes` is <= tau.
    Returns (area, lowest z, highest z, pieces); empty gives (0, inf, -inf, [])."""
    d = signed(p_tri, normals)
    area, lo, hi, pieces = 0.0, math.inf, -math.inf, []
    for t in range(len(p_tri)):
        if not all((d[t, :, k] <= tau).any() for k in planes):
            continue
        poly_p = list(p_tri[t])
        poly_v = [np.array([d[t, i, k] for k in planes]) for i in range(3)]
        for j in range(len(planes)):
            poly_p, poly_v = clip(poly_p, poly_v, tau, j)
            if not poly_p:
                break
        if not poly_p:
            continue
        pieces.append(poly_p)
        z = [q[2] for q in poly_p]
        lo, hi = min(lo, min(z)), max(hi, max(z))
        for i in range(1, len(poly_p) - 1):
            area += 0.5 * np.linalg.norm(np.cross(poly_p[i] - poly_p[0], poly_p[i + 1] - poly_p[0]))
    return area, lo, hi, pieces


def band_columns(pieces, width):
    """The report's coaptation height: the largest axial extent of the zone
    over radial columns [c w, (c+1) w) of distance from the axis."""
    cols = {}
    for poly in pieces:
        r = [math.hypot(q[0], q[1]) for q in poly]
        for c in range(math.floor(min(r) / width), math.floor(max(r) / width) + 1):
            pp = list(poly)
            vv = [np.array([c * width - math.hypot(q[0], q[1]), math.hypot(q[0], q[1]) - (c + 1) * width])
                  for q in pp]
            for j in (0, 1):
                pp, vv = clip(pp, vv, 0.0, j)
                if not pp:
                    break
            if not pp:
                continue
            z = [q[2] for q in pp]
            lo, hi = cols.get(c, (math.inf, -math.inf))
            cols[c] = (min(lo, min(z)), max(hi, max(z)))
    return max((hi - lo for lo, hi in cols.values()), default=0.0)


def coapt_measures(p_tri, normals, tau):
    per = [coapt_zone(p_tri, normals, tau, [k]) for k in (0, 1)]
    ext = [max(hi - lo, 0.0) for _, lo, hi, _ in per]
    both, clo, chi, _ = coapt_zone(p_tri, normals, tau, [0, 1])
    return {
        "area": per[0][0] + per[1][0],
        # Each point once: the bench sums the planes' zones.
        "area_union": per[0][0] + per[1][0] - both,
        "height": max(ext),
        "height_per_plane": ext,
        "columns": max(band_columns(z[3], 0.5) for z in per),
        "columns_fine": max(band_columns(z[3], 0.02) for z in per),
        "central": max(chi - clo, 0.0),
    }


# ------------------------------------------------------------ free edge


def free_edge_chain(tris, boundary):
    """Boundary edges with a free node, ordered into one chain of nodes."""
    count = {}
    for t in tris:
        for k in range(3):
            a, b = int(t[k]), int(t[(k + 1) % 3])
            e = (min(a, b), max(a, b))
            count[e] = count.get(e, 0) + 1
    edges = [e for e, c in count.items() if c == 1 and (boundary[e[0]] == 2 or boundary[e[1]] == 2)]
    nbr = {}
    for a, b in edges:
        nbr.setdefault(a, []).append(b)
        nbr.setdefault(b, []).append(a)
    ends = [v for v, n in nbr.items() if len(n) == 1]
    if len(ends) != 2 or any(len(n) > 2 for n in nbr.values()):
        return None
    chain, prev = [ends[0]], None
    while len(chain) <= len(nbr):
        nxt = [v for v in nbr[chain[-1]] if v != prev]
        if not nxt:
            break
        prev = chain[-1]
        chain.append(nxt[0])
    return chain if len(chain) == len(nbr) else None


def point_at_half_length(chain, x_ref, x):
    """The point of the closed free edge at half the reference arc length."""
    seg = np.linalg.norm(np.diff(x_ref[chain], axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    half = s[-1] / 2
    i = int(np.searchsorted(s, half) - 1)
    i = min(max(i, 0), len(seg) - 1)
    w = (half - s[i]) / seg[i]
    a, b = chain[i], chain[i + 1]
    return x[a] + (x[b] - x[a]) * w, min(abs(half - s[i]), abs(s[i + 1] - half))


def nearest_axis_point(chain, x):
    """coapt's report: the free-edge point (on the segments) nearest the axis."""
    best = None
    for a, b in zip(chain[:-1], chain[1:]):
        p, q = x[a], x[b]
        d = q - p
        dd = d[0] ** 2 + d[1] ** 2
        t = min(max(-(p[0] * d[0] + p[1] * d[1]) / dd, 0.0), 1.0) if dd > 0 else 0.0
        r = p + d * t
        rr = math.hypot(r[0], r[1])
        if best is None or rr < best[0]:
            best = (rr, r)
    return best


# ------------------------------------------------------------------ main


def selftest():
    """Known answers on a sheet parallel to one plane: a parallelogram whose
    axial thickness is 3 mm at every radius but which rises 0.5 mm per mm
    outwards (whole extent 6 mm, area 18 mm2); then the same sheet tilted so
    its distance from the plane runs 0 -> 0.5 mm across it (half of it, 9 mm2,
    inside 0.25 mm)."""
    centre = 0.0
    normals = []
    for side in (-1.0, 1.0):
        a = centre + side * math.pi / 3.0
        n = np.cross([0.0, 0.0, 1.0], [math.cos(a), math.sin(a), 0.0])
        if n @ np.array([1.0, 0.0, 0.0]) > 0:
            n = -n
        normals.append(n)
    normals = np.array(normals)
    u = np.array([math.cos(-math.pi / 3), math.sin(-math.pi / 3), 0.0])  # plane 0's commissure
    nz = 6
    ok = True

    def sheet(dist, nr):
        pts = {}
        for i in range(nr + 1):
            for j in range(nz + 1):
                r = 2.0 + 6.0 * i / nr
                z = 0.5 * (r - 2.0) + 3.0 * j / nz
                pts[i, j] = u * r + np.array([0, 0, z]) - normals[0] * dist(r, z)
        tris = []
        for i in range(nr):
            for j in range(nz):
                a, b, c, d = pts[i, j], pts[i + 1, j], pts[i + 1, j + 1], pts[i, j + 1]
                tris += [[a, b, c], [a, c, d]]
        return np.array(tris)

    def check(name, got, want, tol):
        nonlocal ok
        good = abs(got - want) <= tol
        ok &= good
        print(f"  {name:44} {got:9.4f}  expected {want:g} +- {tol:g}  {'ok' if good else 'FAIL'}")

    p = sheet(lambda r, z: 0.1, 12)
    th = their_measures(p, normals, 0.25)
    co = coapt_measures(p, normals, 0.12)
    print("selftest: parallel sheet 0.1 mm from plane 0")
    check("their area (mm2)", th["area"], 18.0, 1e-9)
    check("their length, 501 columns (mm)", th["length"], 3.0, 1e-9)
    check("their central (mm)", th["central"], 0.0, 0.0)
    check("coapt area (mm2)", co["area"], 18.0, 1e-9)
    check("coapt whole-zone extent (mm)", co["height"], 6.0, 1e-9)
    # Columns by distance from the axis, the sheet 0.1 mm off the plane:
    # r = sqrt(R^2 + 0.01) moves the column edges by under 0.003 mm.
    check("coapt 0.5 mm columns (mm)", co["columns"], 3.25, 2e-3)
    # 11 columns so the zone's edge (r = 5 mm) falls inside triangles.
    p = sheet(lambda r, z: 0.5 * (r - 2.0) / 6.0, 11)
    th = their_measures(p, normals, 0.25)
    co = coapt_measures(p, normals, 0.25)
    half = 9.0 * math.hypot(1.0, 0.5 / 6.0)  # half the tilted sheet
    strip = 6.0 / 11 / 16 * 3.0 * math.hypot(1.0, 0.5 / 6.0)  # one refined strip
    print("selftest: sheet tilted 0 -> 0.5 mm from plane 0")
    check("coapt cut area (mm2)", co["area"], half, 1e-9)
    # Full refined triangles only: short of the cut by less than one strip.
    check("their area (mm2)", th["area"], half - strip / 2, strip / 2)
    check("their length, 501 columns (mm)", th["length"], 3.0, 1e-9)
    return ok


def rel(a, b):
    """(a - b) / b; None when b is 0 and a is not (printed as n/a)."""
    if b == 0:
        return None if a != 0 else 0.0
    return (a - b) / b


def pct(a, b, fmt="{:+6.1f} %"):
    r = rel(a, b)
    return "n/a" if r is None else fmt.format(100 * r)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("nodes", nargs="?", help="closed_h<H>.csv from `bench close --dump` (triangles beside it)")
    ap.add_argument("bench", nargs="?", help="the same run's `bench close --csv` file (one row)")
    ap.add_argument("--selftest", action="store_true", help="check the measures on sheets with known answers, exit 1 on failure")
    ap.add_argument("--thickness", type=float, default=0.5, help="leaflet thickness, mm (their margin is half of it)")
    ap.add_argument("--touch", type=float, default=0.12, help="coapt's eta2 = 0.01 R, mm (crates/bench/src/close.rs TOUCH)")
    ap.add_argument("--their-origin-z", type=float, default=-1.5,
                    help="bench z of their frame's origin (their commissures are at +Hc = 1.5 mm), mm")
    args = ap.parse_args()
    if args.selftest:
        sys.exit(0 if selftest() else 1)
    if not (args.nodes and args.bench):
        ap.error("NODES and BENCH are required (or --selftest)")

    a = read_nodes(args.nodes)
    tris_path = args.nodes[:-4] + ".tris.csv" if args.nodes.endswith(".csv") else args.nodes + ".tris.csv"
    tris = read_tris(tris_path, len(a))
    bench = read_bench(args.bench)
    x_ref, x, boundary, d_dump = a[:, 1:4], a[:, 4:7], a[:, 7].astype(int), a[:, 9:11]
    if not ((boundary == 1).any() and (boundary == 2).any()):
        fail(args.nodes, "needs sutured (1) and free (2) boundary nodes")

    normals, _ = their_planes(x_ref, boundary)
    mine = signed(x, normals)
    # Their planes against coapt's (the dump's d0 d1, either order).
    dev = min(np.abs(mine - d_dump).max(), np.abs(mine[:, ::-1] - d_dump).max())
    if dev > 1e-6:
        print(f"note: their planes differ from coapt's by up to {dev:.3g} mm", file=sys.stderr)

    p_tri = x[tris]
    margin = 0.5 * args.thickness
    th = their_measures(p_tri, normals, margin)
    th_touch = their_measures(p_tri, normals, args.touch)
    co = coapt_measures(p_tri, normals, args.touch)
    co_margin = coapt_measures(p_tri, normals, margin)

    bad = []
    if abs(co["area"] - bench["contact_area_mm2"]) > 1e-4 + 1e-6 * bench["contact_area_mm2"]:
        bad.append(f"area {co['area']:.6f} vs bench {bench['contact_area_mm2']}")
    if abs(co["height"] - bench["coaptation_height_mm"]) > 1e-4:
        bad.append(f"height {co['height']:.6f} vs bench {bench['coaptation_height_mm']}")
    if abs(x[:, 2].min() - bench["lowest_mm"]) > 1e-4:
        bad.append(f"lowest {x[:, 2].min():.6f} vs bench {bench['lowest_mm']}")

    # The plane of the three cusps' lowest fixed nodes: the other cusps are
    # this one turned by 120 degrees, so it is level at the lowest sutured z.
    z_plane = x[boundary == 1, 2].min()
    # Their billowing point: lowest node among those below their origin.
    zt = x[:, 2] - args.their_origin_z
    cand = zt < 0
    z_low = x[cand, 2].min() if cand.any() else z_plane
    billow_their = abs(z_low - z_plane)
    billow_coapt = max(z_plane - x[:, 2].min(), 0.0)

    chain = free_edge_chain(tris, boundary)
    if chain is None:
        fail(tris_path, "the free edge is not one chain of boundary edges")
    fe_mid, off = point_at_half_length(chain, x_ref, x)
    eff_their = abs(fe_mid[2] - z_plane)
    r_near, p_near = nearest_axis_point(chain, x)
    eff_coapt = p_near[2] - z_plane
    closure_degree = float(np.hypot(x[:, 0], x[:, 1]).min())

    rows = [
        ("coaptation area (mm2)",
         f"refined (h/16) triangles with every vertex < {margin:g} mm from a plane, both planes",
         th["area"], co["area"], f"bench area_mm2: zone <= {args.touch:g} mm, cut in triangles"),
        ("length of coaptation (mm)",
         "largest axial up-down over 501 radial columns of labelled edges, larger plane",
         th["length"], co["height"], "bench coapt_h: axial extent of the cut zone, larger plane"),
        ("central coaptation (mm)",
         f"axial extent of vertices < {margin:g} mm from both planes",
         th["central"], co["central"], f"report's triple zone by the bench rule (<= {args.touch:g} mm of both)"),
        ("effective height (mm)",
         "free-edge centre (half arc length) above the lowest-fixed-node plane",
         eff_their, eff_coapt, "report: free-edge point nearest the axis above that plane"),
        ("billowing (mm)",
         "lowest node below the lowest-fixed-node plane",
         billow_their, billow_coapt, "report: depth below the plane of the lowest sutured points"),
    ]
    print(f"{args.nodes}: h {bench['h_mm']:g} mm, {len(x)} nodes, {len(tris)} triangles; "
          f"bench wall {bench['wall_s']:.2f} s (suturing included)")
    print(f"their margin 0.5 x {args.thickness:g} = {margin:g} mm, coapt eta2 {args.touch:g} mm; "
          f"their planes vs coapt's: {dev:.1e} mm; refined to {th['triangles']} triangles")
    print(f"{'measure':28} {'theirs':>8} {'coapt':>8} {'diff':>8}  their definition | coapt's")
    for name, their_def, tv, cv, coapt_def in rows:
        print(f"{name:28} {tv:8.3f} {cv:8.3f} {pct(tv, cv, '{:7.1f}%'):>8}  {their_def} | {coapt_def}")
    print(f"{'form closed valve':28} {str(th['closed']):>8} {str(co['central'] > 0):>8} {'':>8}  "
          "vertices near both planes exist | report: a triple zone exists")
    print(f"{'closure degree (mm)':28} {closure_degree:8.3f} {'-':>8} {'':>8}  "
          "nearest node to the axis, across it | (no coapt counterpart)")
    print()
    print("tests of the explanations: theirs against coapt's with the margin made equal")
    tm = f"{args.touch:g}"
    mm = f"{margin:g}"

    def line(what, tv, cv):
        print(f"  {what:58} theirs {tv:7.3f}  coapt {cv:7.3f}  {pct(tv, cv)}")

    line(f"area (mm2), both at {tm} mm", th_touch["area"], co["area"])
    line(f"area (mm2), both at {mm} mm", th["area"], co_margin["area"])
    line(f"area, coapt's union (each point once), at {tm} mm", th_touch["area"], co["area_union"])
    line(f"area, coapt's union (each point once), at {mm} mm", th["area"], co_margin["area_union"])
    line(f"length vs whole-zone extent (mm), both at {tm} mm", th_touch["length"], co["height"])
    line(f"length vs whole-zone extent (mm), both at {mm} mm", th["length"], co_margin["height"])
    line(f"length vs report rule, 0.5 mm columns (mm), at {tm} mm", th_touch["length"], co["columns"])
    line(f"length vs report rule, 0.5 mm columns (mm), at {mm} mm", th["length"], co_margin["columns"])
    line(f"length vs 0.02 mm columns (mm), at {tm} mm", th_touch["length"], co["columns_fine"])
    line(f"length vs 0.02 mm columns (mm), at {mm} mm", th["length"], co_margin["columns_fine"])
    line(f"central (mm), both at {tm} mm", th_touch["central"], co["central"])
    line(f"central (mm), both at {mm} mm", th["central"], co_margin["central"])
    print(f"  their area per plane {th['area_per_plane'][0]:.3f} + {th['area_per_plane'][1]:.3f} mm2 "
          "(the part near the axis within the margin of both is counted once in the total)")
    print(f"  free-edge centre: z {fe_mid[2]:.3f} mm, {math.hypot(fe_mid[0], fe_mid[1]):.3f} mm from the axis "
          f"({off:.3f} mm of arc from a node); nearest-axis point: z {p_near[2]:.3f} mm, r {r_near:.3f} mm; "
          f"lowest sutured z {z_plane:.3f}, lowest node z {x[:, 2].min():.3f} mm")
    if bad:
        for b in bad:
            print(f"recomputed bench value disagrees: {b}", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
