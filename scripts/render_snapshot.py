#!/usr/bin/python3
"""Render a ringsim snapshot (extended XYZ, docs/OUTPUT.md "Snapshots") to PNG.

Spheres S are drawn orange, linkers L (solid cylinders) blue-grey, and the
members of target rings (a bond-graph component of 4 S and 4 L closed into
one 8-cycle: 8 bonds, every body with exactly 2) red. Bonds are thick dark
lines from the sphere centre to the bonded end of the linker (the end face
centre nearest the sphere; minimum image in periodic boxes), drawn on top of
the bodies so that connectivity stays visible. Bodies that straddle a
periodic boundary are drawn whole at their centre.

Up to --max-mesh bodies are drawn as shaded low-poly surfaces (10 x 6 sphere
quads, 12-sided capped cylinders) in one depth-sorted collection; above it,
spheres become scatter points and linkers line segments.

Needs only numpy and matplotlib (Debian: python3-numpy python3-matplotlib);
runs headless (Agg). Exit status: 0 written, 1 unreadable or malformed input,
2 bad command line.
"""

import argparse
import sys
import textwrap

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection  # noqa: E402

SPHERE_RGB = np.array([0.95, 0.60, 0.22])       # orange
LINKER_RGB = np.array([0.50, 0.57, 0.66])       # blue-grey
TARGET_SPHERE_RGB = np.array([0.86, 0.12, 0.12])  # red
TARGET_LINKER_RGB = np.array([0.62, 0.08, 0.10])  # dark red
BOND_RGB = (0.12, 0.12, 0.12)
SPHERE_LON, SPHERE_LAT, CYL_SIDES = 10, 6, 12


class SnapshotError(Exception):
    """Malformed snapshot file; the message names the line."""


# ---- reading -------------------------------------------------------------------

def parse_key_values(text, lineno):
    """extxyz comment line: key=value, key="quoted value" (backslash escapes), bare key = T."""
    kv, i, n = {}, 0, len(text)
    while True:
        while i < n and text[i].isspace():
            i += 1
        if i >= n:
            return kv
        k0 = i
        while i < n and text[i] != "=" and not text[i].isspace():
            i += 1
        key = text[k0:i].lower()
        if not key:
            raise SnapshotError(f"line {lineno}: empty key at column {k0 + 1}")
        value = "T"
        if i < n and text[i] == "=":
            i += 1
            chars = []
            if i < n and text[i] == '"':
                i += 1
                closed = False
                while i < n:
                    if text[i] == "\\" and i + 1 < n:
                        chars.append(text[i + 1])
                        i += 2
                    elif text[i] == '"':
                        closed, i = True, i + 1
                        break
                    else:
                        chars.append(text[i])
                        i += 1
                if not closed:
                    raise SnapshotError(f"line {lineno}: unterminated quoted value of key '{key}'")
            else:
                while i < n and not text[i].isspace():
                    chars.append(text[i])
                    i += 1
            value = "".join(chars)
        kv[key] = value


def read_snapshot(path):
    """Returns a dict: time, box, periodic, comment, sphere (bool[N]), pos, radius,
    axis, half_length (arrays), object (int[N]), bonds (int[B, 2], sphere id, linker id),
    bond_ends (int[B], 0 = a = x + h u, 1 = b = x - h u; None when the file has no bond_ends)."""
    with open(path, "r", encoding="utf-8") as f:
        lines = f.read().splitlines()
    if not lines:
        raise SnapshotError("line 1: empty file")
    try:
        n = int(lines[0].strip())
    except ValueError:
        raise SnapshotError(f"line 1: expected the number of bodies, got '{lines[0]}'") from None
    if n < 0:
        raise SnapshotError("line 1: negative number of bodies")
    if len(lines) < 2:
        raise SnapshotError("line 2: missing the comment line")
    kv = parse_key_values(lines[1], 2)
    for key in ("lattice", "properties", "time"):
        if key not in kv:
            raise SnapshotError(f"line 2: missing key {key}")
    try:
        lat = [float(v) for v in kv["lattice"].split()]
        time = float(kv["time"])
    except ValueError:
        raise SnapshotError("line 2: Lattice or Time is not numeric") from None
    if len(lat) != 9 or lat[0] <= 0 or any(lat[k] != 0.0 for k in (1, 2, 3, 5, 6, 7)) \
            or lat[4] != lat[0] or lat[8] != lat[0]:
        raise SnapshotError(f"line 2: Lattice=\"{kv['lattice']}\" is not a cube L 0 0 0 L 0 0 0 L")
    pbc = kv.get("pbc", "T T T").split()
    periodic = bool(pbc) and pbc[0].lower() in ("t", "true", "1")

    fields = kv["properties"].split(":")
    if len(fields) % 3:
        raise SnapshotError("line 2: Properties is not a list of name:type:count triplets")
    cols, col = {}, 0
    for k in range(0, len(fields), 3):
        try:
            name, count = fields[k].lower(), int(fields[k + 2])
        except ValueError:
            raise SnapshotError(f"line 2: Properties column count '{fields[k + 2]}' is not an integer") from None
        cols[name] = (col, count)
        col += count
    need = {"species": 1, "pos": 3, "radius": 1, "axis": 3, "half_length": 1}
    for name, count in need.items():
        if cols.get(name, (0, -1))[1] != count:
            raise SnapshotError(f"line 2: Properties needs the column {name} with {count} values")

    if len(lines) < 2 + n:
        raise SnapshotError(f"line {len(lines) + 1}: end of file; expected {n} body lines")
    sphere = np.zeros(n, dtype=bool)
    num = np.zeros((n, 8))
    obj = np.zeros(n, dtype=int)
    c_sp = cols["species"][0]
    picks = [cols["pos"][0], cols["pos"][0] + 1, cols["pos"][0] + 2, cols["radius"][0],
             cols["axis"][0], cols["axis"][0] + 1, cols["axis"][0] + 2, cols["half_length"][0]]
    c_obj = cols.get("object", (None, 0))[0]
    for i in range(n):
        lineno = 3 + i
        tok = lines[2 + i].split()
        if len(tok) != col:
            raise SnapshotError(f"line {lineno}: expected {col} fields, got {len(tok)}")
        if tok[c_sp] not in ("S", "L"):
            raise SnapshotError(f"line {lineno}: species '{tok[c_sp]}' is neither S nor L")
        sphere[i] = tok[c_sp] == "S"
        try:
            num[i] = [float(tok[c]) for c in picks]
            if c_obj is not None:
                obj[i] = int(tok[c_obj])
        except ValueError:
            raise SnapshotError(f"line {lineno}: a numeric field is not a number") from None
    if not np.all(np.isfinite(num)):
        raise SnapshotError("a body line holds a non-finite number")
    for i in np.flatnonzero(~sphere):
        if not np.linalg.norm(num[i, 4:7]) > 0.0:
            raise SnapshotError(f"line {3 + i}: linker axis is zero")

    bonds = []
    for tok in kv.get("bonds", "").split():
        a, sep, b = tok.partition("-")
        try:
            s_id, l_id = int(a), int(b)
        except ValueError:
            raise SnapshotError(f"line 2: bond '{tok}' is not 'sphere-linker'") from None
        if not (sep and 0 <= s_id < n and 0 <= l_id < n and sphere[s_id] and not sphere[l_id]):
            raise SnapshotError(f"line 2: bond '{tok}' is not a (sphere id, linker id) pair")
        bonds.append((s_id, l_id))
    ends = None
    if "bond_ends" in kv:
        toks = kv["bond_ends"].split()
        if len(toks) != len(bonds) or any(t not in ("0", "1") for t in toks):
            raise SnapshotError(f"line 2: bond_ends needs one 0 (a) or 1 (b) per bond ({len(bonds)})")
        ends = np.array([int(t) for t in toks], dtype=int)
    return {
        "time": time, "box": lat[0], "periodic": periodic, "comment": kv.get("comment", ""),
        "sphere": sphere, "pos": num[:, 0:3], "radius": num[:, 3], "axis": num[:, 4:7],
        "half_length": num[:, 7], "object": obj,
        "bonds": np.array(bonds, dtype=int).reshape(-1, 2),
        "bond_ends": ends,
    }


# ---- bond graph ------------------------------------------------------------------

def target_members(snap):
    """Boolean mask of bodies in target rings: components with 4 S, 4 L, 8 bonds and
    every degree 2 (8 vertices, 8 edges, degree <= 2 force a single 8-cycle, which
    alternates S and L because every bond joins a sphere and a linker)."""
    n = len(snap["sphere"])
    parent = np.arange(n)

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    degree = np.zeros(n, dtype=int)
    for s, l in snap["bonds"]:
        degree[s] += 1
        degree[l] += 1
        rs, rl = find(s), find(l)
        if rs != rl:
            parent[rs] = rl
    roots = np.array([find(i) for i in range(n)], dtype=int)
    mask = np.zeros(n, dtype=bool)
    if n == 0:
        return mask
    n_s = np.bincount(roots, weights=snap["sphere"], minlength=n)
    n_all = np.bincount(roots, minlength=n)
    n_edges = np.zeros(n, dtype=int)
    for s, _ in snap["bonds"]:
        n_edges[roots[s]] += 1
    deg_ok = np.bincount(roots, weights=(degree == 2), minlength=n)
    is_target = (n_all == 8) & (n_s == 4) & (n_edges == 8) & (deg_ok == 8)
    mask[:] = is_target[roots]
    return mask


def bond_segments(snap):
    """(B, 2, 3): sphere centre -> bonded linker end (minimum image when periodic); the
    nearest end stands in when the file does not say which end (no bond_ends)."""
    bonds = snap["bonds"]
    if len(bonds) == 0:
        return np.zeros((0, 2, 3))
    ps = snap["pos"][bonds[:, 0]]
    pl = snap["pos"][bonds[:, 1]]
    h = snap["half_length"][bonds[:, 1]][:, None] * snap["axis"][bonds[:, 1]]
    seen = []
    for end in (pl + h, pl - h):
        d = end - ps
        if snap["periodic"]:
            d -= snap["box"] * np.round(d / snap["box"])
        seen.append(d)
    if snap.get("bond_ends") is not None:
        pick_b = snap["bond_ends"] == 1
    else:
        pick_b = np.sum(seen[1] * seen[1], axis=1) < np.sum(seen[0] * seen[0], axis=1)
    return np.stack([ps, ps + np.where(pick_b[:, None], seen[1], seen[0])], axis=1)


# ---- meshes ------------------------------------------------------------------------

def unit_sphere_quads():
    """(F, 4, 3) quads of the unit sphere and their outward normals (F, 3)."""
    th = np.linspace(0.0, np.pi, SPHERE_LAT + 1)
    ph = np.linspace(0.0, 2.0 * np.pi, SPHERE_LON + 1)
    quads = []
    for i in range(SPHERE_LAT):
        for j in range(SPHERE_LON):
            corners = [(th[i], ph[j]), (th[i], ph[j + 1]), (th[i + 1], ph[j + 1]), (th[i + 1], ph[j])]
            quads.append([[np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)] for t, p in corners])
    quads = np.array(quads)
    normals = quads.mean(axis=1)
    return quads, normals / np.linalg.norm(normals, axis=1, keepdims=True)


def frames(axis):
    """Orthonormal (e1, e2) perpendicular to each unit axis (N, 3)."""
    helper = np.where((np.abs(axis[:, 0]) < 0.9)[:, None], [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(axis, e1)


def sphere_polys(pos, radius):
    quads, normals = unit_sphere_quads()
    verts = pos[:, None, None, :] + radius[:, None, None, None] * quads[None]
    return verts.reshape(-1, 4, 3), np.tile(normals, (len(pos), 1))


def cylinder_polys(pos, axis, radius, half_length):
    """Side quads (M, 4, 3) with normals, and cap polygons (2N, CYL_SIDES, 3) with normals."""
    e1, e2 = frames(axis)
    ang = np.linspace(0.0, 2.0 * np.pi, CYL_SIDES + 1)
    c, s = np.cos(ang), np.sin(ang)
    ring = c[None, :, None] * e1[:, None, :] + s[None, :, None] * e2[:, None, :]   # (N, K+1, 3)
    rim = radius[:, None, None] * ring
    top = pos[:, None, :] + half_length[:, None, None] * axis[:, None, :] + rim
    bot = pos[:, None, :] - half_length[:, None, None] * axis[:, None, :] + rim
    side = np.stack([bot[:, :-1], bot[:, 1:], top[:, 1:], top[:, :-1]], axis=2)   # (N, K, 4, 3)
    mid = 0.5 * (ang[:-1] + ang[1:])
    side_n = np.cos(mid)[None, :, None] * e1[:, None, :] + np.sin(mid)[None, :, None] * e2[:, None, :]
    caps = np.concatenate([top[:, :-1], bot[:, :-1]], axis=0)
    caps_n = np.concatenate([axis, -axis], axis=0)
    return side.reshape(-1, 4, 3), side_n.reshape(-1, 3), caps, caps_n


def shade(rgb, normals, light):
    """Lambert shading with ambient light; two-sided so no face turns black."""
    lam = np.abs(normals @ light)
    k = (0.35 + 0.65 * lam)[:, None]
    return np.clip(rgb * k, 0.0, 1.0)


# ---- drawing --------------------------------------------------------------------------

def draw_box(ax, L):
    c = np.array([[x, y, z] for x in (0, L) for y in (0, L) for z in (0, L)], dtype=float)
    edges = [(a, b) for a in range(8) for b in range(a + 1, 8) if np.sum(c[a] != c[b]) == 1]
    ax.add_collection3d(Line3DCollection([c[[a, b]] for a, b in edges], colors="0.45",
                                         linewidths=0.8))


def render(snap, out, elev, azim, dpi, max_mesh, size):
    n = len(snap["sphere"])
    target = target_members(snap)
    sph = snap["sphere"]
    fig = plt.figure(figsize=(size, size))
    ax = fig.add_subplot(projection="3d")
    ax.computed_zorder = False  # keep our order: box, bodies, bonds on top
    L = snap["box"]
    draw_box(ax, L)

    # Light from the viewer's side (above and to the left of the view direction).
    e, a = np.radians(elev), np.radians(azim)
    view = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    light = view + np.array([0.0, 0.0, 0.6])
    light /= np.linalg.norm(light)

    s_rgb = np.where(target[sph][:, None], TARGET_SPHERE_RGB, SPHERE_RGB)
    l_rgb = np.where(target[~sph][:, None], TARGET_LINKER_RGB, LINKER_RGB)
    if n <= max_mesh:
        polys, colors = [], []
        if np.any(sph):
            v, nrm = sphere_polys(snap["pos"][sph], snap["radius"][sph])
            per = len(v) // int(np.sum(sph))
            polys.extend(v)
            colors.append(shade(np.repeat(s_rgb, per, axis=0), nrm, light))
        if np.any(~sph):
            side, side_n, caps, caps_n = cylinder_polys(
                snap["pos"][~sph], snap["axis"][~sph], snap["radius"][~sph], snap["half_length"][~sph])
            polys.extend(side)
            colors.append(shade(np.repeat(l_rgb, CYL_SIDES, axis=0), side_n, light))
            polys.extend(caps)
            colors.append(shade(np.concatenate([l_rgb, l_rgb]), caps_n, light))
        if polys:
            fc = np.concatenate(colors)
            coll = Poly3DCollection(polys, facecolors=fc, edgecolors=fc, linewidths=0.15)
            ax.add_collection3d(coll)
    else:
        # Many bodies: points and segments (sizes only roughly proportional to radii).
        p = snap["pos"]
        if np.any(sph):
            ax.scatter(p[sph, 0], p[sph, 1], p[sph, 2], s=6.0 * snap["radius"][sph] ** 2,
                       c=s_rgb, depthshade=True, linewidths=0)
        if np.any(~sph):
            h = snap["half_length"][~sph][:, None] * snap["axis"][~sph]
            segs = np.stack([p[~sph] - h, p[~sph] + h], axis=1)
            ax.add_collection3d(Line3DCollection(segs, colors=l_rgb, linewidths=2.0))

    segs = bond_segments(snap)
    if len(segs):
        ax.add_collection3d(Line3DCollection(segs, colors=[BOND_RGB], linewidths=2.4))

    ax.set_xlim(0, L)
    ax.set_ylim(0, L)
    ax.set_zlim(0, L)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z")
    ax.view_init(elev=elev, azim=azim)

    n_target = int(np.sum(target)) // 8
    head = (f"t = {snap['time']:.6g}   {int(np.sum(sph))} S, {int(np.sum(~sph))} L, "
            f"{len(snap['bonds'])} bonds, {n_target} target ring{'s' if n_target != 1 else ''}, "
            f"{'periodic' if snap['periodic'] else 'reflective'} box {L:g}")
    title = head if not snap["comment"] else head + "\n" + "\n".join(textwrap.wrap(snap["comment"], 90))
    ax.set_title(title, fontsize=9)
    handles = [Patch(color=SPHERE_RGB, label="sphere S"), Patch(color=LINKER_RGB, label="linker L"),
               Patch(color=TARGET_SPHERE_RGB, label="target ring (4S+4L)"),
               Line2D([], [], color=BOND_RGB, lw=2.4, label="bond")]
    ax.legend(handles=handles, loc="upper left", fontsize=8, frameon=False)
    fig.savefig(out, dpi=dpi, bbox_inches="tight")
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(
        description="Render a ringsim extended XYZ snapshot to PNG (spheres orange, linkers "
                    "blue-grey, target rings red, bonds dark).")
    ap.add_argument("file", help="snapshot written by ringsim (extended XYZ)")
    ap.add_argument("-o", "--output", required=True, help="PNG file to write")
    ap.add_argument("--elev", type=float, default=20.0, help="view elevation in degrees (20)")
    ap.add_argument("--azim", type=float, default=35.0, help="view azimuth in degrees (35)")
    ap.add_argument("--dpi", type=int, default=120, help="resolution (120)")
    ap.add_argument("--size", type=float, default=7.0, help="figure edge in inches (7)")
    ap.add_argument("--max-mesh", type=int, default=2000,
                    help="above this many bodies draw points and segments instead of surfaces (2000)")
    args = ap.parse_args(argv)
    if args.dpi <= 0 or args.size <= 0:
        ap.error("--dpi and --size must be positive")
    # Matplotlib draws at most 2^16 pixels along an edge.
    if args.dpi * args.size >= 2 ** 16:
        ap.error(f"--dpi x --size = {args.dpi * args.size:g} pixels: must be below {2 ** 16}")
    if not (np.isfinite(args.elev) and np.isfinite(args.azim)):
        ap.error("--elev and --azim must be finite numbers of degrees")
    try:
        snap = read_snapshot(args.file)
    except (OSError, UnicodeDecodeError, SnapshotError) as err:  # UnicodeDecodeError: not a text file
        print(f"render_snapshot: {args.file}: {err}", file=sys.stderr)
        return 1
    try:
        render(snap, args.output, args.elev, args.azim, args.dpi, args.max_mesh, args.size)
    except OSError as err:
        print(f"render_snapshot: {args.output}: {err}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
