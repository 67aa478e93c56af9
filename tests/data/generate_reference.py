#!/usr/bin/python3
"""Recomputes the reference values of cylinder_distance.json and
free_rotation.json from their inputs, independently of ringsim's C++ code.

  generate_reference.py --check [--quick]   recompute, compare with the stored
                                            files, exit 1 past the tolerances
  generate_reference.py --write [--out DIR] recompute and write both files
                                            (default DIR: beside this script)

The inputs (cylinder poses; principal moments and initial angular velocities)
are arbitrary test points and are read from the stored files; every output
(the distances; the energy, body angular momentum and the states at later
times) is recomputed here. --quick checks every 10th cylinder pose and every
4th body (about 15 s instead of about 3 minutes on a busy 2-core machine).

Cylinder distance (two solid cylinders A, B, radius r, half-length h):
  d = min over p in A of dist(p, B). dist(., B) is the distance to a convex
  set, so the problem is convex, and it is C^1 wherever A and B are apart.
  The solid cylinder is the product of a segment (along the axis) and a disc
  (across it), so the closest point of B to p is found by clamping the axial
  coordinate to [-h, h] and the radial one to [0, r]. p is parametrised by
  (s, x, y): p = c_A + s a_A + r (x u + y v), |s| <= h, x^2 + y^2 <= 1, and
  d^2 is minimised with SLSQP from 6 starts; the same again with the roles
  of A and B swapped (one of the two sometimes stops early on the flat
  minimiser sets of parallel poses), the smaller value kept. It is
  certified by weak duality: for any unit n, min_B n.y - max_A n.x <= d,
  with the support
  function of a cylinder max_A n.x = n.c + h |n.a| + r sqrt(1 - (n.a)^2);
  n is first taken along the primal minimiser's gap and then the bound is
  maximised over n (Nelder-Mead on the sphere). The stored distance is the
  primal value; the gap (primal - dual) bounds its error.

Free rotation (torque-free rigid body, principal moments I, body angular
velocity w, orientation q world <- body as a unit quaternion w, x, y, z):
  Euler's equations I1 w1' = (I2 - I3) w2 w3 (and cyclic), and the quaternion
  kinematics q' = q * (0, w) / 2, integrated with SciPy's DOP853 at
  rtol 1e-13, atol 1e-15. The quaternion is renormalised only when written,
  and written with w >= 0 (q and -q are the same rotation; the stored files
  use that sign).
  The integration is repeated at rtol 1e-12; the difference estimates the
  error. Conservation of the energy and of the world angular momentum
  R(q) I w is reported as a further check.
"""

import argparse
import json
import os
import sys
import time

try:
    import numpy as np
    from scipy.integrate import solve_ivp
    from scipy.optimize import minimize
except ImportError as e:  # ctest reads 77 as "skipped"
    print(f"generate_reference.py: needs NumPy and SciPy (python3-numpy, python3-scipy): {e}", file=sys.stderr)
    sys.exit(77)

HERE = os.path.dirname(os.path.abspath(__file__))

# --check fails past these (absolute) differences from the stored values. The
# C++ tests compare with the stored values at 3e-9 (distance) and 1e-9
# (rotation), so the reference must be at least that good.
TOL_DISTANCE = 1e-9
TOL_ROTATION = 1e-10


# ---- cylinder distance -------------------------------------------------------

def _frame(a):
    """Two unit vectors completing the unit vector a to an orthonormal frame."""
    t = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(a, t)
    u /= np.linalg.norm(u)
    return u, np.cross(a, u)


def closest_point_solid_cylinder(p, c, a, r, h):
    """Closest point to p of the solid cylinder (centre c, unit axis a)."""
    d = p - c
    t = d @ a
    w = d - t * a
    rho = np.linalg.norm(w)
    q = c + min(max(t, -h), h) * a
    if rho > r:
        q = q + (r / rho) * w
    else:
        q = q + w
    return q


def support(n, c, a, r, h):
    """max over the solid cylinder of n . x."""
    na = n @ a
    return n @ c + h * abs(na) + r * np.sqrt(max(0.0, 1.0 - na * na))


def dual_value(n, A, B):
    """Weak-duality lower bound on the distance for the direction n (A to B)."""
    n = n / np.linalg.norm(n)
    return -support(-n, *B) - support(n, *A)


def cylinder_distance(A, B):
    """(distance, certified gap) between solid cylinders A = (c, a, r, h), B:
    the problem solved over either solid (the other one's distance exact),
    the smaller upper and the larger lower bound kept."""
    (u1, l1), (u2, l2) = one_sided_distance(A, B), one_sided_distance(B, A)
    upper = min(u1, u2)
    return upper, upper - max(l1, l2)


def one_sided_distance(A, B):
    """(upper, lower) bounds on the distance: min over p in A of dist(p, B)."""
    cA, aA, r, h = A
    u, v = _frame(aA)

    def point(z):
        return cA + z[0] * aA + r * (z[1] * u + z[2] * v)

    def f(z):
        p = point(z)
        g = p - closest_point_solid_cylinder(p, *B)
        return g @ g

    def grad(z):
        p = point(z)
        g = 2.0 * (p - closest_point_solid_cylinder(p, *B))
        return np.array([g @ aA, r * (g @ u), r * (g @ v)])

    disc = {"type": "ineq", "fun": lambda z: 1.0 - z[1] ** 2 - z[2] ** 2,
            "jac": lambda z: np.array([0.0, -2.0 * z[1], -2.0 * z[2]])}
    # Starts: the centre, both cap centres, and three rim points around the axis.
    starts = [(0, 0, 0), (h, 0, 0), (-h, 0, 0), (0.5 * h, 0.9, 0), (-0.5 * h, -0.45, 0.78), (0, -0.45, -0.78)]
    def slsqp(z0):
        res = minimize(f, np.array(z0, float), jac=grad, method="SLSQP", bounds=[(-h, h), (-1, 1), (-1, 1)],
                       constraints=[disc], options={"ftol": 1e-20, "maxiter": 500})
        z = res.x.copy()
        s2 = z[1] ** 2 + z[2] ** 2
        if s2 > 1.0:  # keep the point feasible so that its value is an upper bound
            z[1:] /= np.sqrt(s2)
        return f(z), z

    def neg_dual(ang):
        th, ph = ang
        return -dual_value(np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)]), A, B)

    def bounds(z):
        """(upper, lower): the primal value at z; the dual maximised near its gap direction."""
        p = point(z)
        q = closest_point_solid_cylinder(p, *B)
        upper = np.linalg.norm(q - p)
        n0 = (q - p) / upper
        # Candidate directions: the gap, and the gap made perpendicular to
        # either axis (the dual optimum of parallel and side contacts sits on
        # that kink, where Nelder-Mead converges slowly).
        cands = [n0] + [n0 - (n0 @ a) * a for a in (aA, B[1])]
        lower = max(dual_value(n, A, B) for n in cands if np.linalg.norm(n) > 1e-6)
        th0 = np.arccos(np.clip(n0[2], -1, 1))
        ph0 = np.arctan2(n0[1], n0[0])
        res = minimize(neg_dual, [th0, ph0], method="Nelder-Mead",
                       options={"xatol": 1e-14, "fatol": 1e-17, "maxiter": 4000, "initial_simplex":
                                [[th0, ph0], [th0 + 1e-4, ph0], [th0, ph0 + 1e-4]]})
        return upper, max(lower, -res.fun)

    best = min((slsqp(z0) for z0 in starts), key=lambda t: t[0])
    upper, lower = bounds(best[1])
    # Warm restarts while the certificate is loose (SLSQP can stop early on
    # the flat minimiser sets of parallel poses).
    for _ in range(4):
        if upper - lower <= 1e-13:
            break
        again = slsqp(best[1])
        if again[0] < best[0]:
            best = again
            upper, lower = bounds(best[1])
        else:
            break
    return upper, lower


def cylinder_cases(data, stride):
    r = data["radius"]
    h = 0.5 * data["length"]
    out = []
    for i, c in enumerate(data["cases"]):
        if i % stride:
            continue
        A = (np.array(c["center_a"]), np.array(c["axis_a"]) / np.linalg.norm(c["axis_a"]), r, h)
        B = (np.array(c["center_b"]), np.array(c["axis_b"]) / np.linalg.norm(c["axis_b"]), r, h)
        out.append((i, c, A, B))
    return out


def check_cylinders(data, stride):
    worst = (0.0, None)
    worst_gap = (0.0, None)
    for i, c, A, B in cylinder_cases(data, stride):
        d, gap = cylinder_distance(A, B)
        diff = abs(d - c["distance"])
        if gap > worst_gap[0] or worst_gap[1] is None:
            worst_gap = (gap, f"case {i}")
        if diff > worst[0] or worst[1] is None:
            worst = (diff, f"case {i} ({c['kind']})")
    return worst, worst_gap


# ---- free rotation -----------------------------------------------------------

def quat_mul(p, q):
    w1, x1, y1, z1 = p
    w2, x2, y2, z2 = q
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def quat_rotate(q, v):
    """R(q) v for the unit quaternion q (w, x, y, z)."""
    qv = quat_mul(quat_mul(q, np.concatenate(([0.0], v))), q * np.array([1, -1, -1, -1]))
    return qv[1:]


def rigid_rhs(I):
    I1, I2, I3 = I

    def f(_t, y):
        w = y[:3]
        q = y[3:]
        dw = np.array([(I2 - I3) * w[1] * w[2] / I1, (I3 - I1) * w[2] * w[0] / I2, (I1 - I2) * w[0] * w[1] / I3])
        dq = 0.5 * quat_mul(q, np.concatenate(([0.0], w)))
        return np.concatenate((dw, dq))
    return f


def integrate_body(I, w0, q0, times, rtol):
    y0 = np.concatenate((w0, q0 / np.linalg.norm(q0)))
    sol = solve_ivp(rigid_rhs(I), (0.0, max(times)), y0, method="DOP853", t_eval=times, rtol=rtol, atol=1e-15)
    if not sol.success:
        raise RuntimeError(sol.message)
    return [(sol.y[:3, k], canonical(sol.y[3:, k])) for k in range(len(times))]


def canonical(q):
    """q normalised, of the pair +-q (one rotation) the one with w >= 0."""
    q = q / np.linalg.norm(q)
    return -q if q[0] < 0 else q


def rotation_case(c):
    """Recomputes one case of free_rotation.json from its inputs."""
    I = np.array(c["inertia_principal"], float)
    w0 = np.array(c["omega_body_0"], float)
    q0 = np.array(c["q0_wxyz"], float)
    times = [s["t"] for s in c["states"]]
    states = integrate_body(I, w0, q0, times, 1e-13)
    coarse = integrate_body(I, w0, q0, times, 1e-12)
    err = max(max(np.max(np.abs(w - wc)), np.max(np.abs(q - qc))) for (w, q), (wc, qc) in zip(states, coarse))
    L_body0 = I * w0
    E = 0.5 * w0 @ (I * w0)
    L_world0 = quat_rotate(q0 / np.linalg.norm(q0), L_body0)
    drift = 0.0
    for w, q in states:
        drift = max(drift, abs(0.5 * w @ (I * w) - E) / E, np.max(np.abs(quat_rotate(q, I * w) - L_world0)) / np.linalg.norm(L_body0))
    out = {"inertia_principal": list(I), "omega_body_0": list(w0), "q0_wxyz": c["q0_wxyz"],
           "angular_momentum_body_0": list(L_body0), "energy": float(E),
           "states": [{"t": t, "omega_body": list(w), "q_wxyz": list(q)} for t, (w, q) in zip(times, states)]}
    return out, err, drift


def check_rotation(data, stride):
    worst = (0.0, None)
    worst_err = worst_drift = 0.0
    for k, c in enumerate(data["cases"]):
        if k % stride:
            continue
        new, err, drift = rotation_case(c)
        worst_err = max(worst_err, err)
        worst_drift = max(worst_drift, drift)
        diffs = [abs(new["energy"] - c["energy"]),
                 np.max(np.abs(np.array(new["angular_momentum_body_0"]) - c["angular_momentum_body_0"]))]
        for sn, so in zip(new["states"], c["states"]):
            diffs.append(np.max(np.abs(np.array(sn["omega_body"]) - so["omega_body"])))
            qn, qo = np.array(sn["q_wxyz"]), np.array(so["q_wxyz"])
            diffs.append(min(np.max(np.abs(qn - qo)), np.max(np.abs(qn + qo))))  # q and -q: one rotation
        if max(diffs) > worst[0] or worst[1] is None:
            worst = (float(max(diffs)), f"case {k}")
    return worst, worst_err, worst_drift


# ---- main --------------------------------------------------------------------

def load(name):
    with open(os.path.join(HERE, name)) as f:
        return json.load(f)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    mode = ap.add_mutually_exclusive_group(required=True)
    mode.add_argument("--check", action="store_true", help="recompute and compare with the stored files")
    mode.add_argument("--write", action="store_true", help="recompute and write both files")
    ap.add_argument("--quick", action="store_true", help="with --check: every 10th pose and every 4th body")
    ap.add_argument("--out", default=HERE, help="with --write: the output directory (default: beside this script)")
    args = ap.parse_args()

    cyl = load("cylinder_distance.json")
    rot = load("free_rotation.json")

    if args.write:
        os.makedirs(args.out, exist_ok=True)
        for i, c, A, B in cylinder_cases(cyl, 1):
            c["distance"] = float(cylinder_distance(A, B)[0])
        rot["cases"] = [rotation_case(c)[0] for c in rot["cases"]]
        for name, data in (("cylinder_distance.json", cyl), ("free_rotation.json", rot)):
            with open(os.path.join(args.out, name), "w") as f:
                f.write(json.dumps(data, indent=1))
            print("wrote", os.path.join(args.out, name))
        return 0

    cs, rs = (10, 4) if args.quick else (1, 1)
    t0 = time.time()
    (dmax, dwhere), (gap, gwhere) = check_cylinders(cyl, cs)
    t1 = time.time()
    (rmax, rwhere), rerr, drift = check_rotation(rot, rs)
    t2 = time.time()
    ncyl = len(range(0, len(cyl["cases"]), cs))
    nrot = len(range(0, len(rot["cases"]), rs))
    print(f"cylinder_distance.json: {ncyl} of {len(cyl['cases'])} poses in {t1 - t0:.1f} s; "
          f"max |d - d_stored| = {dmax:.2e} ({dwhere}); max certified gap of the recomputation = {gap:.2e} "
          f"({gwhere}); "
          f"tolerance {TOL_DISTANCE:.0e}")
    print(f"free_rotation.json: {nrot} of {len(rot['cases'])} bodies in {t2 - t1:.1f} s; "
          f"max |x - x_stored| = {rmax:.2e} ({rwhere}); rtol 1e-13 vs 1e-12 = {rerr:.2e}; "
          f"relative drift of E and world L = {drift:.2e}; tolerance {TOL_ROTATION:.0e}")
    ok = dmax <= TOL_DISTANCE and rmax <= TOL_ROTATION
    print("OK" if ok else "FAIL: past the tolerance")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
