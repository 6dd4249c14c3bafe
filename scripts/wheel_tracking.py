#!/usr/bin/env python3
"""How far each wheel follows its command in the steady windows, binned by the kind of command
(both sides one way: "drive"; opposite ways: "turn") and by the larger wheel command (4 rad/s
bins): the median ratio measured / commanded and the largest measured speed per bin.

Reads the `rows` of a `summary.json` written by `drive-sim analyze`, one block per dataset:

    drive-sim analyze ../shared/data/measured/warthog_asphalt.csv --out out/an
    python3 scripts/wheel_tracking.py out/an/summary.json

Why: a motor that holds its speed whatever the load tracks 1.00 in every bin; one whose torque
falls with its speed gives up speed where the ground resists (the "turn" bins) and reaches a
lower ceiling there (README, "Twins and compare").
"""
import json
import statistics
import sys


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: wheel_tracking.py SUMMARY_JSON")
    summary = json.load(open(sys.argv[1]))
    for d in summary["datasets"]:
        print(f"== {d['dataset']}  (T/U wheels {d['t_area_pct_wheels']:.1f} %)")
        bins = {}
        for r in d["rows"]:
            if (r["window"] or 0) < 1 or r["excluded"] is not None:
                continue
            cl, cr = r["cmd_left_rad_s"], r["cmd_right_rad_s"]
            kind = "turn" if cl * cr < 0 else "drive"
            top = int(max(abs(cl), abs(cr)) // 4) * 4
            for cmd, measured in ((cl, r["left_rad_s"]), (cr, r["right_rad_s"])):
                if abs(cmd) > 1.0:
                    bins.setdefault((kind, top), []).append((measured / cmd, abs(measured)))
        print(f"  {'kind':5} {'|cmd| bin':>10} {'wheels':>7} {'median w/cmd':>13} {'max |w|':>8}")
        for (kind, top), v in sorted(bins.items()):
            print(
                f"  {kind:5} {top:>4}-{top + 4:<5} {len(v):>7} "
                f"{statistics.median(x[0] for x in v):>13.2f} {max(x[1] for x in v):>8.1f}"
            )


if __name__ == "__main__":
    main()
