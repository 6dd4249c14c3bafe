#!/usr/bin/env python3
"""Where a transfer-function difference map of `drive-sim compare` differs: the RMS of one
channel's difference (sim - real) by band of a wheel's command, with the share of the map's
squared difference each band holds.

    python3 scripts/map_difference_by_command.py OUT/comparison.json [--sim 0]
        [--channel slip_left_rad_s] [--wheel left] [--band 2] [--radius 0.3] [--baseline 1.08]

The map's grid is in body commands (vx, wz); a wheel's command is (vx -+ wz b/2) / r (left
minus, right plus), with the robot's radius and baseline (the Warthog's by default).
"""

import argparse
import collections
import json
import math


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("comparison")
    ap.add_argument("--sim", type=int, default=0, help="index of the simulated log in the comparison")
    ap.add_argument("--channel", default="slip_left_rad_s")
    ap.add_argument("--wheel", choices=["left", "right"], default="left")
    ap.add_argument("--band", type=float, default=2.0, help="band width, rad/s")
    ap.add_argument("--radius", type=float, default=0.3)
    ap.add_argument("--baseline", type=float, default=1.08)
    args = ap.parse_args()
    with open(args.comparison) as f:
        maps = json.load(f)["sims"][args.sim]["maps"]
    values = maps["values"][maps["channels"].index(args.channel)]
    nvx = len(maps["vx_m_s"])
    sign = -1.0 if args.wheel == "left" else 1.0
    bands = collections.defaultdict(list)
    for j, wz in enumerate(maps["wz_rad_s"]):
        for i, vx in enumerate(maps["vx_m_s"]):
            v = values[j * nvx + i]
            if v is None or (isinstance(v, float) and math.isnan(v)):
                continue
            w = (vx + sign * wz * args.baseline / 2.0) / args.radius
            bands[math.floor(w / args.band)].append(v * v)
    total = sum(sum(b) for b in bands.values())
    print(f"{args.channel}, by {args.wheel} wheel command ({args.band:g} rad/s bands): points, RMS, share of the squared difference")
    for k in sorted(bands):
        b = bands[k]
        lo = k * args.band
        print(f"  [{lo:6.1f}, {lo + args.band:6.1f}) {len(b):5d}  {math.sqrt(sum(b) / len(b)):.3f}  {100 * sum(b) / total:5.1f} %")


if __name__ == "__main__":
    main()
