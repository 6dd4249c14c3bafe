#!/usr/bin/env python3
"""Declared models and twins against every measured dataset, through `drive-sim compare`.

Issue 13's table: for each measured run, the declared robot and terrain and a twin calibrated
with the simulator model on the run's odd steps each run their own DRIVE (150 steps, seed 0),
and `compare` judges both against the run's even steps, which the twin's calibration never saw.

    python3 scripts/twin_table.py [--bin target/release/drive-sim] [--out out/twin_table]
                                  [--datasets warthog_gravel,...] [--steps 150]

Prints a Markdown table (one row per model and dataset) and writes it to OUT/table.md, with
every command it ran in OUT/commands.txt. Each stage is skipped when its output exists, so an
interrupted run resumes; delete OUT to start over.
"""

import argparse
import json
import os
import shlex
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
DATA = os.path.join(REPO, "..", "shared", "data", "measured")
DATASETS = ["warthog_asphalt", "warthog_gravel", "warthog_ice", "husky_2023"]


def declared_models(dataset):
    """The robot and terrain the CSV's metadata names (an unlabelled run starts from asphalt,
    as `calibrate` does)."""
    with open(os.path.join(DATA, dataset + ".json")) as f:
        meta = json.load(f)
    terrain = meta.get("terrain") or "asphalt"
    if terrain == "unlabelled":
        terrain = "asphalt"
    return meta["robot"], terrain


def run(cmd, log):
    log.write(" ".join(shlex.quote(c) for c in cmd) + "\n")
    log.flush()
    t0 = time.time()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.time() - t0


def metric(sim, key):
    for m in sim["metrics"]:
        if m["metric"] == key:
            return m
    return None


def fmt_interval(m):
    ci = m.get("difference_ci95")
    if not ci:
        return f"{m['difference']:+.3f}"
    return f"{m['difference']:+.3f} [{ci['lower']:+.3f}, {ci['upper']:+.3f}]"


def row(dataset, model, sim, real):
    rho = metric(sim, "median_rho")
    area_b = metric(sim, "t_area_pct_body")
    area_w = metric(sim, "t_area_pct_wheels")
    slips = [m for m in sim["metrics"] if m["metric"].startswith("median_slip")]
    slips_sig = [m["metric"].replace("median_slip_", "") for m in slips if m["significant"]]
    tf = ", ".join(f"{t['ratio']:.2f}" for t in sim["transfer"])
    v = sim["verdict"]
    verdict = "reproduces" if v["reproduces"] else "differs (" + ", ".join(
        v["significant"] + v["areas_beyond_tolerance"] + v["tf_beyond_yardstick"]) + ")"
    area = lambda m: f"{m['sim']:.1f} % ({m['difference']:+.1f} pp)" if m else "–"
    return (
        f"| {dataset} | {model} | {rho['sim']:.3f} (real {rho['real']:.3f}) | {fmt_interval(rho)} | "
        f"{', '.join(slips_sig) or 'none'} | {area(area_b)} | {area(area_w)} | {tf} | {verdict} |"
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", default=os.path.join(REPO, "target", "release", "drive-sim"))
    ap.add_argument("--out", default=os.path.join(REPO, "out", "twin_table"))
    ap.add_argument("--datasets", default=",".join(DATASETS))
    ap.add_argument("--steps", type=int, default=150)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    if not os.path.exists(args.bin):
        sys.exit(f"error: no binary at {args.bin} (cargo build --release, or --bin PATH)")
    os.makedirs(args.out, exist_ok=True)
    log = open(os.path.join(args.out, "commands.txt"), "a")
    lines = [
        "| dataset | model | median ρ | ρ difference [95 %] | median slips differing | T/U body | "
        "T/U wheels | TF RMS / yardstick (vx, vy, wz, left, right) | verdict |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for d in args.datasets.split(","):
        csv = os.path.join(DATA, d + ".csv")
        if not os.path.exists(csv):
            sys.exit(f"error: no measured dataset {csv}")
        robot, terrain = declared_models(d)
        sims = os.path.join(args.out, "sim")
        cal = os.path.join(args.out, "cal_odd_" + d)
        declared = os.path.join(sims, f"declared_{d}.mcap")
        twin = os.path.join(sims, f"twin_{d}.mcap")
        cmp_dir = os.path.join(args.out, "cmp_" + d)
        common = ["--steps", str(args.steps), "--seed", str(args.seed), "--out", sims, "--quiet"]
        if not os.path.exists(declared):
            dt = run([args.bin, "run", "--robot", robot, "--terrain", terrain, *common,
                      "--name", f"declared_{d}"], log)
            print(f"{d}: declared run {dt:.0f} s", file=sys.stderr)
        if not os.path.exists(os.path.join(cal, "twin", "robot.toml")):
            dt = run([args.bin, "calibrate", csv, "--model", "simulator", "--use-steps", "odd",
                      "--out", cal], log)
            print(f"{d}: twin calibration (odd steps) {dt:.0f} s", file=sys.stderr)
        if not os.path.exists(twin):
            dt = run([args.bin, "run", "--robot", os.path.join(cal, "twin", "robot.toml"),
                      "--terrain", os.path.join(cal, "twin", "terrain.toml"), *common,
                      "--name", f"twin_{d}"], log)
            print(f"{d}: twin run {dt:.0f} s", file=sys.stderr)
        if not os.path.exists(os.path.join(cmp_dir, "comparison.json")):
            run([args.bin, "compare", csv, declared, twin, "--real-steps", "even",
                 "--out", cmp_dir], log)
        with open(os.path.join(cmp_dir, "comparison.json")) as f:
            report = json.load(f)
        for sim, model in zip(report["sims"], [f"declared {robot} + {terrain}", "twin (odd steps)"]):
            lines.append(row(d, model, sim, report["real"]))
    table = "\n".join(lines)
    print(table)
    with open(os.path.join(args.out, "table.md"), "w") as f:
        f.write(table + "\n")


if __name__ == "__main__":
    main()
