#!/usr/bin/env python3
"""The lateral velocity of a run's steps regressed on its measured yaw rate, centripetal
acceleration and forward speed, without any model: vy = a + b·wz + c·vx·wz + d·vx, by least
squares over the steps' steady windows, for all steps and for those commanded forward and backward, with 95 %
intervals from a bootstrap by step (1000 resamples of the steps, seed 0). A robot turning
about a point x_ICR along its axis has b = −x_ICR (`icr_longitudinal_offset`); a tyre slip angle
in turns gives c (`centripetal_slip`); a robot moving at an angle ψ to its axis, d = tan ψ
(`crab_angle`). Reads the `summary.json` that `drive-sim analyze` writes
(its per-window rows: measured vx, vy, wz and the command).

    drive-sim analyze ../shared/data/measured/husky_2023.csv --out out/analysis_husky
    python3 scripts/lateral_slip_regression.py out/analysis_husky/summary.json [more summary.json]
"""
import json
import random
import sys


N = 4


def solve(rows):
    """Least squares of vy on (1, wz, vx·wz, vx) through the normal equations (Gauss–Jordan)."""
    x = [[1.0, r["wz_rad_s"], r["vx_m_s"] * r["wz_rad_s"], r["vx_m_s"]] for r in rows]
    y = [r["vy_m_s"] for r in rows]
    a = [[sum(xi[i] * xi[j] for xi in x) for j in range(N)] + [sum(xi[i] * yi for xi, yi in zip(x, y))]
         for i in range(N)]
    for c in range(N):
        p = max(range(c, N), key=lambda r: abs(a[r][c]))
        a[c], a[p] = a[p], a[c]
        for r in range(N):
            if r != c:
                f = a[r][c] / a[c][c]
                a[r] = [v - f * w for v, w in zip(a[r], a[c])]
    coef = [a[i][N] / a[i][i] for i in range(N)]
    res = [yi - sum(c * v for c, v in zip(coef, xi)) for xi, yi in zip(x, y)]
    sd = (sum(r * r for r in res) / max(len(res) - N, 1)) ** 0.5
    return coef, sd


def by_step_interval(rows, resamples=1000, seed=0):
    """95 % percentile intervals of b, c and d, resampling whole steps (a step's windows share its
    command and its ground, so they are not independent)."""
    steps = {}
    for r in rows:
        steps.setdefault(r["step"], []).append(r)
    keys = sorted(steps)
    rng = random.Random(seed)
    draws = [[], [], []]
    for _ in range(resamples):
        draw = [w for k in rng.choices(keys, k=len(keys)) for w in steps[k]]
        coef, _ = solve(draw)
        for v, c in zip(draws, coef[1:]):
            v.append(c)
    q = lambda v, p: sorted(v)[min(int(p * len(v)), len(v) - 1)]
    return [(q(v, 0.025), q(v, 0.975)) for v in draws]


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    for path in sys.argv[1:]:
        with open(path) as f:
            summary = json.load(f)
        for d in summary["datasets"]:
            # The windows of the steps kept (a step-level row has no window number).
            rows = [r for r in d["rows"] if r["excluded"] is None and r["window"] is not None]
            print(f"{d['dataset']}: vy = a + b·wz + c·vx·wz + d·vx over steady windows (m/s, rad/s)")
            for part, keep in (("all", lambda r: True),
                               ("forward", lambda r: r["cmd_vx_m_s"] > 0.05),
                               ("reverse", lambda r: r["cmd_vx_m_s"] < -0.05)):
                sel = [r for r in rows if keep(r)]
                if len(sel) < 4:
                    print(f"  {part:8s} too few windows ({len(sel)})")
                    continue
                (a, b, c, dd), sd = solve(sel)
                (lb, hb), (lc, hc), (ld, hd) = by_step_interval(sel)
                print(f"  {part:8s} n={len(sel):4d}  a {a:+.3f} m/s  b {b:+.3f} [{lb:+.3f}, {hb:+.3f}] m"
                      f"  c {c:+.3f} [{lc:+.3f}, {hc:+.3f}] s  d {dd:+.3f} [{ld:+.3f}, {hd:+.3f}]"
                      f"  residual SD {sd:.3f} m/s")


if __name__ == "__main__":
    main()
