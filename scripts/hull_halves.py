#!/usr/bin/env python3
"""Why a run's odd and even steps cover different areas of T: which steps of one half carry its
wheel-frame hull beyond the other half's.

Reads the `rows` of a `summary.json` written by `drive-sim analyze` (one value per step, its
first steady window) and prints, per dataset, the hull area of the commanded wheel speeds (S)
and of the reached ones (T) in each half, then every step of `--half` whose reached point alone
adds more than `--min` (rad/s)² to the other half's T hull, with its command.

    drive-sim analyze ../shared/data/measured/warthog_asphalt.csv --out out/an
    python3 scripts/hull_halves.py out/an/summary.json [--half even] [--min 3] [--halvings 500]

With `--halvings N` it also asks whether the odd/even split is unusual: it splits the run's
steps into two random halves N times (seeded) and prints where the odd/even difference of the T
hulls falls among theirs (median, 90th and 95th percentiles, and the share of random halvings
that differ at least as much, and by the target's `--tolerance` or more), in percentage points
of the area of U (the commanded square,
`--u-half-width` rad/s either side of zero). A difference that random halvings often reach is
the luck of the split, which no model chosen on one half can foresee in the other.

Areas are unclipped hulls in (rad/s)², so they differ from `t_area_pct_wheels` (clipped by U,
as a percentage of it) by that clipping and scale; the question here is which steps make the
difference.

With `--space body` the same questions are asked of the body frame: the commanded (vx, wz) and
the reached ones (each step's steady state), each half's T hull clipped by U as `t_area_pct_body` is (U built from the
summary's `nominal`: the wheel-speed square mapped to the body, cut by the largest speed and
yaw rate), in percentage points of U's area; the whole run's value is printed beside the
summary's `t_area_pct_body`, which it must equal. Why: a twin judged on the even steps after being chosen on the odd ones cannot
cover area the odd steps never showed (README, "Can `compare` tell them apart?").
"""
import argparse
import json
import random


def hull(points):
    """Convex hull, counter-clockwise (Andrew's monotone chain)."""
    p = sorted(set(points))
    if len(p) < 3:
        return p

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for q in p:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], q) <= 0:
            lower.pop()
        lower.append(q)
    for q in reversed(p):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], q) <= 0:
            upper.pop()
        upper.append(q)
    return lower[:-1] + upper[:-1]


def polygon_signed(p):
    """Signed area of a polygon (shoelace): positive when counter-clockwise."""
    n = len(p)
    return 0.5 * sum(p[i][0] * p[(i + 1) % n][1] - p[(i + 1) % n][0] * p[i][1] for i in range(n)) if n >= 3 else 0.0


def area(points):
    """Area of the points' convex hull."""
    return abs(polygon_signed(hull(points)))


def clip(poly, a, c, d):
    """The part of a convex polygon where a*x + c*y <= d (Sutherland-Hodgman, one half-plane)."""
    out = []
    n = len(poly)
    for i in range(n):
        p, q = poly[i], poly[(i + 1) % n]
        fp, fq = a * p[0] + c * p[1] - d, a * q[0] + c * q[1] - d
        if fp <= 0:
            out.append(p)
        if fp * fq < 0:
            t = fp / (fp - fq)
            out.append((p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])))
    return out


def clip_convex(poly, window):
    """A convex polygon cut by a convex, counter-clockwise one."""
    n = len(window)
    for i in range(n):
        (x0, y0), (x1, y1) = window[i], window[(i + 1) % n]
        # Inside is left of the edge: -(y1-y0) x + (x1-x0) y >= -(y1-y0) x0 + (x1-x0) y0.
        a, c = y1 - y0, -(x1 - x0)
        poly = clip(poly, a, c, a * x0 + c * y0)
        if not poly:
            break
    return poly


def u_body(nominal):
    """U in the body frame (vx, wz), counter-clockwise: the wheel-speed square mapped to the body,
    cut by the largest linear speed and yaw rate (the analysis' command space)."""
    r, b, wm = nominal["wheel_radius_m"], nominal["baseline_m"], nominal["max_wheel_rad_s"]
    to_b = lambda left, right: (r * (left + right) / 2.0, r * (right - left) / b)
    poly = [to_b(-wm, -wm), to_b(wm, -wm), to_b(wm, wm), to_b(-wm, wm)]
    if polygon_signed(poly) < 0:
        poly.reverse()
    vm, am = nominal["max_lin_m_s"], nominal["max_ang_rad_s"]
    for a, c, d in [(1.0, 0.0, vm), (-1.0, 0.0, vm), (0.0, 1.0, am), (0.0, -1.0, am)]:
        poly = clip(poly, a, c, d)
    return poly


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("summary")
    ap.add_argument("--half", choices=["odd", "even"], default="even", help="the half whose steps are examined")
    ap.add_argument("--min", type=float, default=3.0, help="smallest added area reported, (rad/s)²")
    ap.add_argument("--halvings", type=int, default=0, help="random halvings to place the odd/even split among")
    ap.add_argument("--u-half-width", type=float, default=16.67, help="U's half-width, rad/s (the Warthog's)")
    ap.add_argument("--tolerance", type=float, default=5.0, help="the target's T/U tolerance, pp of U")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--space", choices=["wheels", "body"], default="wheels",
                    help="wheels: (left, right) rad/s, unclipped hulls; body: (vx, wz), hulls clipped by U")
    args = ap.parse_args()
    for d in json.load(open(args.summary))["datasets"]:
        steps = {}
        for r in d["rows"]:
            # Wheels: each step's first steady window; body: its steady state (the mean of its
            # steady windows, `window` null), the points `t_area_pct_body` is the hull of.
            first = (r["window"] or 0) >= 1 if args.space == "wheels" else r["window"] is None
            if first and r["excluded"] is None:
                steps.setdefault(r["step"], r)
        half = {"odd": [k for k in sorted(steps) if k % 2 == 1], "even": [k for k in sorted(steps) if k % 2 == 0]}
        if args.space == "body":
            u = u_body(d["nominal"])
            u_area = abs(polygon_signed(u))
            cmd = lambda k: (steps[k]["cmd_vx_m_s"], steps[k]["cmd_wz_rad_s"])
            reached = lambda k: (steps[k]["vx_m_s"], steps[k]["wz_rad_s"])
            measure = lambda pts: abs(polygon_signed(clip_convex(hull(pts), u))) / u_area * 100.0
            unit = "% of U"
            whole = measure([reached(k) for k in steps])
            print(f"== {d['dataset']} (body frame; the whole run's T {whole:.2f} % of U, "
                  f"the summary's t_area_pct_body {d['t_area_pct_body']:.2f})")
        else:
            u_area = (2.0 * args.u_half_width) ** 2
            cmd = lambda k: (steps[k]["cmd_left_rad_s"], steps[k]["cmd_right_rad_s"])
            reached = lambda k: (steps[k]["left_rad_s"], steps[k]["right_rad_s"])
            measure = area
            unit = "(rad/s)²"
            print(f"== {d['dataset']}")
        for name, ks in half.items():
            print(f"  {name:4} {len(ks):3} steps: S hull {measure([cmd(k) for k in ks]):5.1f}, "
                  f"T hull {measure([reached(k) for k in ks]):5.1f} {unit}")
        other = [reached(k) for k in half["odd" if args.half == "even" else "even"]]
        base = measure(other)
        for k in half[args.half]:
            added = measure(other + [reached(k)]) - base
            if added > args.min:
                print(f"  {args.half} step {k}: command ({cmd(k)[0]:.1f}, {cmd(k)[1]:.1f}) reached "
                      f"({reached(k)[0]:.2f}, {reached(k)[1]:.2f}): adds {added:.1f} {unit} to the other half's T hull")
        if args.halvings > 0:
            scale = 100.0 / u_area if args.space == "wheels" else 1.0
            gap = lambda a, b: abs(measure([reached(k) for k in a]) - measure([reached(k) for k in b])) * scale
            split = gap(half["odd"], half["even"])
            rng = random.Random(args.seed)
            keys = sorted(steps)
            diffs = []
            for _ in range(args.halvings):
                k = keys[:]
                rng.shuffle(k)
                diffs.append(gap(k[: len(k) // 2], k[len(k) // 2:]))
            diffs.sort()
            q = lambda p: diffs[min(len(diffs) - 1, int(p * len(diffs)))]
            print(f"  T hulls' odd/even difference {split:.1f} pp of U; {args.halvings} random halvings: median "
                  f"{q(0.5):.1f}, 90 % {q(0.9):.1f}, 95 % {q(0.95):.1f} pp; "
                  f"{sum(x >= split for x in diffs) / len(diffs):.0%} differ at least as much, "
                  f"{sum(x >= args.tolerance for x in diffs) / len(diffs):.0%} by {args.tolerance:g} pp or more")


if __name__ == "__main__":
    main()
