#!/usr/bin/env python3
"""How much a run's steady windows scatter in body speed over wheel speed, window by window.

In a steady window of a straight or gently curving step on hard ground, the body moves at its
wheels' speed give or take the slip: the ratio of the body's forward speed to the one its
measured wheels imply is near 1 in every window of a model that reads a pose at every sample.
A logged pose that stands still between the odometry's updates (`drive-sim analyze`, its "pose
updates" line) moves each window's slope with where the updates fall against the window's
ends. This script reads the `rows` of `summary.json` files written by `drive-sim analyze` and
prints, per dataset, over the windows 1 and 2 of the steps whose command's wheel differential
`|u_R − u_L| / |u_R + u_L|` is below 0.5 and whose wheels imply at least 1 m/s on the Warthog
(0.55 m/s on the Husky, the same wheel speed): the median ratio and its spread, 1.4826 times
the median absolute deviation (a standard deviation for Gaussian errors, robust to the few
windows with a localisation fault), in window 1, window 2 and both.

    drive-sim analyze ../shared/data/measured/*.csv --out out/an_measured
    python3 scripts/window_scatter.py out/an_measured/summary.json [more summary.json ...]
"""
import json
import statistics as st
import sys

RADIUS_M = {"husky": 0.165}


def spread(v):
    m = st.median(v)
    return m, 1.4826 * st.median(abs(x - m) for x in v)


def main():
    print("| dataset | windows | median ratio | spread, window 1 | window 2 | both |")
    print("|---|---|---|---|---|---|")
    for path in sys.argv[1:]:
        with open(path) as f:
            summary = json.load(f)
        for d in summary["datasets"]:
            r = RADIUS_M.get(d["robot"], 0.3)
            by_window = {1: [], 2: []}
            for x in d["rows"]:
                if x["excluded"] or x["window"] not in (1, 2):
                    continue
                cl, cr = x["cmd_left_rad_s"], x["cmd_right_rad_s"]
                if abs(cr + cl) < 1e-9 or abs(cr - cl) / abs(cr + cl) >= 0.5:
                    continue
                wheels = r * (x["left_rad_s"] + x["right_rad_s"]) / 2
                if abs(wheels) < r / 0.3:
                    continue
                by_window[x["window"]].append(x["vx_m_s"] / wheels)
            both = by_window[1] + by_window[2]
            if len(both) < 10:
                continue
            m, s = spread(both)
            print(f"| {d['dataset']} | {len(both)} | {m:.3f} | {spread(by_window[1])[1]:.3f} | "
                  f"{spread(by_window[2])[1]:.3f} | {s:.3f} |")


if __name__ == "__main__":
    main()
