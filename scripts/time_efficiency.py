#!/usr/bin/env python3
"""Where the simulated DRIVE's time goes, for a declared robot and optionally a twin, on the
paper's minimum safe area and on a site as large as the paper's for that terrain.

For each model (the declared ROBOT on TERRAIN, and the twin given by --twin, a directory holding
robot.toml and terrain.toml) and each safe area (the robot file's minimum, 45 x 20 m for the
Warthog, 9 x 6 m for the Husky, and --site, e.g. 50x25 for the paper's 1250 m2 asphalt site),
runs `drive-sim run` for 150 steps with seeds 0, 1, 2 and prints the paper's "time data
gathering" (run.json summary.data_gathering_fraction), the interruptions per step and the
re-orientation breakdown.

    python3 scripts/time_efficiency.py [--robot warthog] --terrain asphalt --site 50x25 \\
        [--twin out/twin_results/warthog_asphalt/twin] [--bin target/release/drive-sim] [--out out/time_efficiency]

(--twin: e.g. a twin `drive-sim twin` writes, `python3 scripts/twin_results.py`.)

Writes OUT/table.md and every command to OUT/commands.txt; runs whose log exists are reused.
"""

import argparse
import json
import os

# The logged command runner is the twin table's.
from twin_table import REPO, run

SEEDS = [0, 1, 2]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default=os.path.join(REPO, "target", "release", "drive-sim"))
    ap.add_argument("--out", default=os.path.join(REPO, "out", "time_efficiency"))
    ap.add_argument("--robot", default="warthog")
    ap.add_argument("--terrain", default="asphalt")
    ap.add_argument("--site", default="50x25", help="LENGTHxWIDTH of the paper's site, metres")
    ap.add_argument("--twin", default=None, help="directory with robot.toml and terrain.toml")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    models = [("declared " + args.robot + " + " + args.terrain, args.robot, args.terrain)]
    if args.twin:
        models.append(("twin " + os.path.relpath(args.twin, REPO), os.path.join(args.twin, "robot.toml"),
                       os.path.join(args.twin, "terrain.toml")))
    sites = [("robot file's minimum", None), (args.site.replace("x", " x ") + " m", args.site)]
    lines = [
        "| model | safe area | data gathering (seeds 0, 1, 2) | mean | interruptions / step | "
        "re-orientation turning / driving / stopping, % of time | "
        "re-orientation per interruption, s (stop / drive / turn) |",
        "|---|---|---|---|---|---|---|",
    ]
    with open(os.path.join(args.out, "commands.txt"), "a") as log:
        for mi, (label, robot, terrain) in enumerate(models):
            for si, (site_label, site) in enumerate(sites):
                rows = []
                for seed in SEEDS:
                    name = f"m{mi}_a{si}_s{seed}"
                    json_path = os.path.join(args.out, name + ".run.json")
                    if not os.path.exists(json_path):
                        cmd = [args.bin, "run", "--robot", robot, "--terrain", terrain, "--steps", "150",
                               "--seed", str(seed), "--out", args.out, "--name", name, "--quiet"]
                        if site:
                            cmd += ["--safe-area", site]
                        run(cmd, log)
                    with open(json_path) as f:
                        rows.append(json.load(f)["summary"])
                g = [100 * r["data_gathering_fraction"] for r in rows]
                ips = [r["interruptions"] / r["steps_completed"] for r in rows]
                share = lambda k: sum(100 * r[k] / r["total_time_s"] for r in rows) / len(rows)
                # Seconds per interruption over the three seeds together.
                per = lambda k: sum(r[k] for r in rows) / max(1, sum(r["interruptions"] for r in rows))
                lines.append(
                    f"| {label} | {site_label} | {', '.join(f'{x:.1f} %' for x in g)} | "
                    f"{sum(g) / len(g):.1f} % | {', '.join(f'{x:.2f}' for x in ips)} | "
                    f"{share('reorientation_turning_s'):.1f} / {share('reorientation_driving_s'):.1f} / "
                    f"{share('reorientation_stopping_s'):.1f} | {per('reorientation_time_s'):.1f} "
                    f"({per('reorientation_stopping_s'):.1f} / {per('reorientation_driving_s'):.1f} / "
                    f"{per('reorientation_turning_s'):.1f}) |")
    table = "\n".join(lines)
    print(table)
    with open(os.path.join(args.out, "table.md"), "w") as f:
        f.write(table + "\n")


if __name__ == "__main__":
    main()
