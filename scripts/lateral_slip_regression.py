#!/usr/bin/env python3
"""The lateral velocity of a run's steps regressed on its measured yaw rate and centripetal
acceleration, without any model: vy = a + b·wz + c·vx·wz, by least squares over the steps'
steady windows, for all steps and for those commanded forward and backward, with 95 %
intervals from a bootstrap by step (1000 resamples of the steps, seed 0). A robot turning
about a point x_ICR along its axis has b = −x_ICR (`icr_longitudinal_offset`); a tyre slip angle
in turns gives c (`centripetal_slip`). Reads the `summary.json` that `drive-sim analyze` writes
(its per-window rows: measured vx, vy, wz and the command).

    drive-sim analyze ../shared/data/measured/husky_2023.csv --out out/analysis_husky
    python3 scripts/lateral_slip_regression.py out/analysis_husky/summary.json [more summary.json]
"""
import json
import random
import sys


def solve(rows):
    """Least squares of vy on (1, wz, vx·wz) through the normal equations (3 × 3, Gauss)."""
    x = [[1.0, r["wz_rad_s"], r["vx_m_s"] * r["wz_rad_s"]] for r in rows]
    y = [r["vy_m_s"] for r in rows]
    a = [[sum(xi[i] * xi[j] for xi in x) for j in range(3)] + [sum(xi[i] * yi for xi, yi in zip(x, y))]
         for i in range(3)]
    for c in range(3):
        p = max(range(c, 3), key=lambda r: abs(a[r][c]))
        a[c], a[p] = a[p], a[c]
        for r in range(3):
            if r != c:
                f = a[r][c] / a[c][c]
                a[r] = [v - f * w for v, w in zip(a[r], a[c])]
    coef = [a[i][3] / a[i][i] for i in range(3)]
    res = [yi - sum(c * v for c, v in zip(coef, xi)) for xi, yi in zip(x, y)]
    sd = (sum(r * r for r in res) / max(len(res) - 3, 1)) ** 0.5
    return coef, sd


def by_step_interval(rows, resamples=1000, seed=0):
    """95 % percentile intervals of b and c, resampling whole steps (a step's windows share its
    command and its ground, so they are not independent)."""
    steps = {}
    for r in rows:
        steps.setdefault(r["step"], []).append(r)
    keys = sorted(steps)
    rng = random.Random(seed)
    bs, cs = [], []
    for _ in range(resamples):
        draw = [w for k in rng.choices(keys, k=len(keys)) for w in steps[k]]
        (_, b, c), _ = solve(draw)
        bs.append(b)
        cs.append(c)
    bs.sort()
    cs.sort()
    q = lambda v, p: v[min(int(p * len(v)), len(v) - 1)]
    return q(bs, 0.025), q(bs, 0.975), q(cs, 0.025), q(cs, 0.975)


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    for path in sys.argv[1:]:
        with open(path) as f:
            summary = json.load(f)
        for d in summary["datasets"]:
            # The windows of the steps kept (a step-level row has no window number).
            rows = [r for r in d["rows"] if r["excluded"] is None and r["window"] is not None]
            print(f"{d['dataset']}: vy = a + b·wz + c·vx·wz over steady windows (m/s, rad/s)")
            for part, keep in (("all", lambda r: True),
                               ("forward", lambda r: r["cmd_vx_m_s"] > 0.05),
                               ("reverse", lambda r: r["cmd_vx_m_s"] < -0.05)):
                sel = [r for r in rows if keep(r)]
                if len(sel) < 4:
                    print(f"  {part:8s} too few windows ({len(sel)})")
                    continue
                (a, b, c), sd = solve(sel)
                lo_b, hi_b, lo_c, hi_c = by_step_interval(sel)
                print(f"  {part:8s} n={len(sel):4d}  a {a:+.3f} m/s  b {b:+.3f} [{lo_b:+.3f}, {hi_b:+.3f}] m"
                      f"  c {c:+.3f} [{lo_c:+.3f}, {hi_c:+.3f}] s  residual SD {sd:.3f} m/s")


if __name__ == "__main__":
    main()
