#!/usr/bin/env python3
"""Writes the thesis scenarios' scenes and HIP trajectories (standard library only).

    python3 scenes/generate.py

thesis-2d: two NURBS curves (rational quadratic 60-degree arcs, radius 40 mm) meeting at a
sharp convex vertex, like Fig. 3.2.1(a), in the pantograph's workspace; the trajectory
reproduces events 1-13 of thesis section 3.2.1.
thesis-3d: a bicubic NURBS bump; the trajectory keeps u constant and moves along v with the
stick / slip / stick / slip sequence of section 3.2.2 (Fig. 3.2.6-3.2.7).
deformable: a taut string (a straight cubic of 12 control points, D-NURBS tension 5 N) and a
drum skin (a flat 10 x 10 bicubic, membrane tension 50 N/m) that the hand pushes in
(`viewer sim --deform`, `viewer deform`, the app's deform toggle); the trajectory presses the
string's middle 4 mm past its rest shape, strokes along it and lets go.
torus: an exact rational biquadratic torus (one 9 x 9 patch, no trajectory), to feel a closed
curved surface in the viewer's 3-D view.
experiments/shapes/shapes-*: the five objects of the shape-identification experiment (not bundled scenes) (thesis section 4.3, Fig.
4.3.1: two curves meeting at a vertex, convex, straight or concave), a graded family from
strongly convex to strongly concave, for experiments/thesis-shapes.json (no trajectory).
"""
import json
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))
RATE = 1000.0  # trajectory samples per second (the sim interpolates anyway)

MATERIAL = {
    "stiffness_n_per_m": 1000.0,
    "damping_ns_per_m": 0.0,
    "mu_static": 0.7,
    "mu_dynamic": 0.5,
}

# --- thesis-2d -------------------------------------------------------------------------
R = 0.04
C0 = (-0.02, 0.06)  # centre of the circle carrying patch 0 (the right-hand curve)
C1 = (0.02, 0.06)  # centre of the circle carrying patch 1 (the left-hand curve)


def arc(c, a0_deg, a1_deg):
    """Rational quadratic arc, counter-clockwise (outward normals), sweep < 90 degrees."""
    a0, a1 = math.radians(a0_deg), math.radians(a1_deg)
    half = (a1 - a0) / 2
    w = math.cos(half)
    mid = a0 + half
    p0 = (c[0] + R * math.cos(a0), c[1] + R * math.sin(a0))
    p1 = (c[0] + R / w * math.cos(mid), c[1] + R / w * math.sin(mid))
    p2 = (c[0] + R * math.cos(a1), c[1] + R * math.sin(a1))
    return {
        "degree": 2,
        "knots": [0, 0, 0, 1, 1, 1],
        "points": [list(p0), list(p1), list(p2)],
        "weights": [1, w, 1],
    }


def polar(c, r, deg):
    a = math.radians(deg)
    return (c[0] + r * math.cos(a), c[1] + r * math.sin(a))


def thesis_2d():
    scene = {
        "format": "scene/1",
        "objects": [
            {
                "name": "two curves meeting at a vertex (thesis Fig. 3.2.1)",
                "material": MATERIAL,
                "patches": [arc(C0, 0.0, 60.0), arc(C1, 120.0, 180.0)],
            }
        ],
    }
    # Waypoint segments: (duration_s, function of s in [0, 1] -> point).
    def radial(deg, r0, r1):
        return lambda s: polar(C0, r0 + (r1 - r0) * s, deg)

    def along(r, d0, d1):
        return lambda s: polar(C0, r, d0 + (d1 - d0) * s)

    x_g, y_g = polar(C0, R - 0.002, 54.0)
    segs = [
        (0.2, radial(20.0, R + 0.005, R - 0.002)),  # -> 1: press in along the normal, 2 mm
        (0.5, along(R - 0.002, 20.0, 35.0)),  # 1 -> 2 -> 3: stuck, breakaway, transition, slip
        (0.2, radial(35.0, R - 0.002, R - 0.004)),  # 3 -> 4 -> 5: press deeper: stuck again
        (0.5, along(R - 0.004, 35.0, 48.0)),  # 5 -> 6 -> 7 -> 8: stuck, breakaway, slip
        (0.2, radial(48.0, R - 0.004, R + 0.005)),  # 8 -> 9: leave the object
        (0.2, along(R + 0.005, 48.0, 54.0)),  # 9 -> 10: outside, towards the corner
        (0.2, radial(54.0, R + 0.005, R - 0.002)),  # 10 -> 11: press in near the corner
        (0.36, lambda s: (x_g - 0.0068 * s, y_g)),  # 11 -> 12 -> 13: horizontally onto curve 2
        (0.16, lambda s: (x_g - 0.0068, y_g)),  # hold
    ]
    return scene, segs


# --- thesis-3d -------------------------------------------------------------------------
# A bicubic Bezier bump over x in [-0.04, 0.04], y in [0.06, 0.12], z up (outward).
XS = [-0.04, -0.0133333, 0.0133333, 0.04]
YS = [0.06, 0.08, 0.10, 0.12]
ZS = [[0.0, 0.0, 0.0, 0.0], [0.0, 0.012, 0.012, 0.0], [0.0, 0.012, 0.012, 0.0], [0.0, 0.0, 0.0, 0.0]]


def bern(i, t):
    return math.comb(3, i) * t**i * (1 - t) ** (3 - i)


def dbern(i, t):
    return 3 * ((bern3(i - 1, t) if i > 0 else 0.0) - (bern3(i, t) if i < 3 else 0.0))


def bern3(i, t):
    # degree-2 Bernstein polynomial B_{i,2}
    return math.comb(2, i) * t**i * (1 - t) ** (2 - i)


def surf(u, v):
    p = [0.0, 0.0, 0.0]
    du = [0.0, 0.0, 0.0]
    dv = [0.0, 0.0, 0.0]
    for i in range(4):
        for j in range(4):
            q = (XS[i], YS[j], ZS[i][j])
            for k in range(3):
                p[k] += bern(i, u) * bern(j, v) * q[k]
                du[k] += dbern(i, u) * bern(j, v) * q[k]
                dv[k] += bern(i, u) * dbern(j, v) * q[k]
    n = cross(du, dv)
    ln = math.sqrt(sum(c * c for c in n))
    return p, [c / ln for c in n]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def thesis_3d():
    scene = {
        "format": "scene/1",
        "objects": [
            {
                "name": "bicubic bump (thesis Fig. 3.2.5)",
                "material": MATERIAL,
                "patches": [
                    {
                        "degree": [3, 3],
                        "knots": [[0, 0, 0, 0, 1, 1, 1, 1], [0, 0, 0, 0, 1, 1, 1, 1]],
                        "points": [[[XS[i], YS[j], ZS[i][j]] for j in range(4)] for i in range(4)],
                    }
                ],
            }
        ],
    }
    U = 0.5

    def at(v, depth):
        p, n = surf(U, v)
        return tuple(p[k] - depth * n[k] for k in range(3))

    segs = [
        (0.2, lambda s: at(0.25, -0.005 + 0.007 * s)),  # 1 -> 2: press in, 2 mm
        (0.5, lambda s: at(0.25 + 0.2 * s, 0.002)),  # 2 -> 3 -> 4: stuck, breakaway, slip along v
        (0.2, lambda s: at(0.45, 0.002 + 0.002 * s)),  # 4 -> 5: press deeper: stuck
        (0.6, lambda s: at(0.45 + 0.25 * s, 0.004)),  # 5 -> 6 -> 7 -> 8: stuck, breakaway, slip
    ]
    return scene, segs


# --- torus -------------------------------------------------------------------------------
def torus(center=(0.0, 0.09, 0.0), major=0.03, minor=0.01):
    """The profile circle (radius `minor`, `major` from the axis) revolved about z: control
    point (i, j) is the unit circle's point i scaled by the profile's x_j, at height z_j, with
    weight w_i w_j (the tensor product of two 9-point rational quadratic circles)."""
    s = math.sqrt(0.5)
    unit = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1), (1, 0)]
    w = [1, s, 1, s, 1, s, 1, s, 1]
    knots = [0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1]
    points, weights = [], []
    for ci, wi in zip(unit, w):
        row, wrow = [], []
        for cj, wj in zip(unit, w):
            x = major + minor * cj[0]
            row.append([center[0] + x * ci[0], center[1] + x * ci[1], center[2] + minor * cj[1]])
            wrow.append(wi * wj)
        points.append(row)
        weights.append(wrow)
    return {
        "format": "scene/1",
        "objects": [
            {
                "name": "torus (R = 30 mm, r = 10 mm, rational biquadratic)",
                "material": MATERIAL,
                "patches": [
                    {"degree": [2, 2], "knots": [knots, knots], "points": points, "weights": weights}
                ],
            }
        ],
    }


def clamped_uniform(p, n):
    inner = n - p
    return [0.0] * (p + 1) + [i / inner for i in range(1, inner)] + [1.0] * (p + 1)


def greville(knots, p, n):
    """Control points at the Greville abscissae make a straight patch's parametrisation
    linear (uniform speed), so arc length and parameter agree."""
    return [sum(knots[i + 1:i + p + 1]) / p for i in range(n)]


def deformable():
    # The string lies above the app's start point (0, 0.11), its outside (normal -y) below:
    # the hand starts outside it and pushes up.
    n, length, y = 12, 0.08, 0.115
    k = clamped_uniform(3, n)
    string = {
        "name": "taut string (D-NURBS, 5 N)",
        "material": {"stiffness_n_per_m": 1000.0, "damping_ns_per_m": 0.0,
                     "mu_static": 0.3, "mu_dynamic": 0.2},
        "patches": [{
            "degree": 3,
            "knots": k,
            "points": [[round(-length / 2 + length * g, 9), y] for g in greville(k, 3, n)],
        }],
        "dynamics": {"density_kg_per_m": 0.1, "damping_ns_per_m2": 10.0, "tension_n": 5.0,
                     "bending_n_m2": 0.0, "fixed": "ends", "plastic": False},
    }
    m, side = 10, 0.1
    kd = clamped_uniform(3, m)
    g = greville(kd, 3, m)
    drum = {
        "name": "drum skin (D-NURBS, 50 N/m)",
        "material": {"stiffness_n_per_m": 1000.0, "damping_ns_per_m": 0.0,
                     "mu_static": 0.3, "mu_dynamic": 0.2},
        "patches": [{
            "degree": [3, 3],
            "knots": [kd, kd],
            "points": [[[round(-side / 2 + side * gu, 9), round(0.09 - side / 2 + side * gv, 9), 0.0]
                        for gv in g] for gu in g],
        }],
        "dynamics": {"density_kg_per_m2": 1.0, "damping_ns_per_m3": 100.0,
                     "tension_n_per_m": 50.0, "bending_n_m": 0.0, "fixed": "boundary",
                     "plastic": False},
    }
    scene = {"format": "scene/1", "objects": [string, drum]}

    def line(a, b):
        return lambda s: (a[0] + (b[0] - a[0]) * s, a[1] + (b[1] - a[1]) * s)

    free, pressed = (0.0, y - 0.010), (0.0, y + 0.004)
    side_point = (0.015, y + 0.004)
    segs = [
        (0.3, line(free, pressed)),  # press the middle 4 mm past the rest shape
        (0.7, line(pressed, pressed)),  # hold: the string settles under the finger
        (0.5, line(pressed, side_point)),  # stroke along it
        (0.5, line(side_point, pressed)),
        (0.3, line(pressed, free)),  # let go: the string springs back
        (0.2, line(free, free)),
    ]
    return scene, segs


# --- shapes-* (thesis section 4.3, Fig. 4.3.1) -----------------------------------------
# A roof: two curves from the ends (+-SHAPE_HALF_WIDTH, SHAPE_BASE_Y) to the vertex
# (0, SHAPE_VERTEX_Y). The chain runs right to left over the top, so its outside (the right
# of its direction, t x k) faces up and the app's start point (0, 0.11) is outside, 15 mm
# above the vertex. Each curve is a quadratic Bezier whose middle control point sits off the
# chord's midpoint along the chord's outward normal by `bulge` times the chord's length:
# > 0 convex, 0 straight, < 0 concave. Fig. 4.3.1 shows two convex objects (a, b), a
# straight one (c) and a concave one (d); the fifth is the stronger concave one, so the five
# are a family of geometrically similar shapes, graded by curvature.
SHAPE_HALF_WIDTH = 0.03
SHAPE_BASE_Y = 0.065
SHAPE_VERTEX_Y = 0.095
SHAPES = [
    ("convex-strong", 0.2),
    ("convex-mild", 0.1),
    ("straight", 0.0),
    ("concave-mild", -0.1),
    ("concave-strong", -0.2),
]


def bowed(p0, p2, bulge):
    dx, dy = p2[0] - p0[0], p2[1] - p0[1]
    # Outward normal of the chord p0 -> p2: t x k = (ty, -tx), times |chord| * bulge.
    p1 = ((p0[0] + p2[0]) / 2 + bulge * dy, (p0[1] + p2[1]) / 2 - bulge * dx)
    return {
        "degree": 2,
        "knots": [0, 0, 0, 1, 1, 1],
        "points": [list(p0), list(p1), list(p2)],
    }


def shape(name, bulge):
    right = (SHAPE_HALF_WIDTH, SHAPE_BASE_Y)
    vertex = (0.0, SHAPE_VERTEX_Y)
    left = (-SHAPE_HALF_WIDTH, SHAPE_BASE_Y)
    return {
        "format": "scene/1",
        "objects": [
            {
                "name": f"{name}: two curves meeting at a vertex (thesis Fig. 4.3.1)",
                "material": MATERIAL,
                "patches": [bowed(right, vertex, bulge), bowed(vertex, left, bulge)],
            }
        ],
    }


def write(name, scene, segs):
    with open(os.path.join(HERE, f"{name}.json"), "w") as f:
        json.dump(scene, f, indent=1)
        f.write("\n")
    dim = len(segs[0][1](0.0))
    header = "t,x,y" if dim == 2 else "t,x,y,z"
    rows = []
    t0 = 0.0
    for dur, fn in segs:
        n = int(round(dur * RATE))
        for k in range(n):
            rows.append((t0 + k / RATE, fn(k / n)))
        t0 += dur
    rows.append((t0, segs[-1][1](1.0)))
    with open(os.path.join(HERE, f"{name}.csv"), "w") as f:
        f.write(header + "\n")
        for t, p in rows:
            f.write(f"{t:.4f}," + ",".join(f"{c:.7f}" for c in p) + "\n")


if __name__ == "__main__":
    write("thesis-2d", *thesis_2d())
    write("thesis-3d", *thesis_3d())
    write("deformable", *deformable())
    with open(os.path.join(HERE, "torus.json"), "w") as f:
        json.dump(torus(), f, indent=1)
        f.write("\n")
    for name, bulge in SHAPES:
        with open(os.path.join(HERE, "..", "experiments", "shapes", f"shapes-{name}.json"), "w") as f:
            json.dump(shape(name, bulge), f, indent=1)
            f.write("\n")
