#!/usr/bin/env python3
"""Declared models and twins against every measured dataset, through `drive-sim compare`.

For each measured run, the declared robot and terrain and a twin calibrated
with the simulator model on the run's odd steps each run their own DRIVE (150 steps, seed 0),
and `compare` judges both against the run's even steps, which the twin's calibration never saw.
Then a twin calibrated on all the steps runs its DRIVE and is judged against the whole run,
beside the declared model (not held out: this twin has seen every step it is
judged on).

    python3 scripts/twin_table.py [--bin target/release/drive-sim] [--out out/twin_table]
                                  [--datasets warthog_gravel,...] [--steps 150]
                                  [--twin-all 'out/timings/{dataset}_simulator']

`--twin-all` takes the all-steps twins from existing calibrations (a path with `{dataset}`)
instead of calibrating again.

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
    as `calibrate` does), and whether the robot is a deployment file: `robots/<dataset>.toml`,
    when there is one, describes the robot as that run configured it (robots/husky_2023.toml)
    and is the declared robot of that run, the one its twins are calibrated from."""
    with open(os.path.join(DATA, dataset + ".json")) as f:
        meta = json.load(f)
    terrain = meta.get("terrain") or "asphalt"
    if terrain == "unlabelled":
        terrain = "asphalt"
    deployment = os.path.join(REPO, "robots", dataset + ".toml")
    if os.path.exists(deployment):
        return os.path.relpath(deployment, REPO), terrain, True
    return meta["robot"], terrain, False


def run(cmd, log):
    log.write(" ".join(shlex.quote(c) for c in cmd) + "\n")
    log.flush()
    t0 = time.time()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.time() - t0


def run_sim(cmd, log, mcap):
    """A DRIVE run; `None` when it ran, else the error drive-sim gave (a twin can fail in closed
    loop where its replays passed: the table says so instead of stopping)."""
    failed = mcap + ".failed"
    if os.path.exists(mcap):
        return None
    if os.path.exists(failed):
        with open(failed) as f:
            return f.read()
    log.write(" ".join(shlex.quote(c) for c in cmd) + "\n")
    log.flush()
    p = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if p.returncode == 0:
        return None
    errors = [l for l in p.stderr.splitlines() if "error:" in l]
    why = (errors[-1] if errors else p.stderr.strip().splitlines()[-1]).split("error: ", 1)[-1]
    with open(failed, "w") as f:
        f.write(why)
    return why


def failed_row(dataset, model, why):
    why = why.split(" (robot stuck")[0]
    short = why if len(why) < 160 else why[:157] + "…"
    return f"| {dataset} | {model} | run failed: {short} | | | | | | |"


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


def row(dataset, model, sim):
    rho = metric(sim, "median_rho")
    area_b = metric(sim, "t_area_pct_body")
    area_w = metric(sim, "t_area_pct_wheels")
    slips = [m for m in sim["metrics"] if m["metric"].startswith("median_slip")]
    slips_sig = [m["metric"].replace("median_slip_", "") for m in slips if m["significant"]]
    rho_sig = " (significant)" if rho["significant"] else ""
    tf = ", ".join(f"{t['ratio']:.2f}" for t in sim["transfer"])
    v = sim["verdict"]
    short = lambda k: k.replace("t_area_pct_", "T/U ").replace("median_", "").replace(
        "slip_", "").replace("_m_s", "").replace("_rad_s", "")
    parts = []
    if v["significant"]:
        parts.append("significant: " + ", ".join(short(k) for k in v["significant"]))
    if v["areas_beyond_tolerance"]:
        parts.append("area > 5 pp: " + ", ".join(short(k) for k in v["areas_beyond_tolerance"]))
    if v["tf_beyond_yardstick"]:
        parts.append("TF > 1.5×: " + ", ".join(short(k) for k in v["tf_beyond_yardstick"]))
    verdict = "**reproduces**" if v["reproduces"] else "differs (" + "; ".join(parts) + ")"
    area = lambda m: f"{m['sim']:.1f} % ({m['difference']:+.1f} pp)" if m else "–"
    return (
        f"| {dataset} | {model} | {rho['sim']:.3f} (real {rho['real']:.3f}) | {fmt_interval(rho)}{rho_sig} | "
        f"{', '.join(slips_sig) or 'none'} | {area(area_b)} | {area(area_w)} | {tf} | {verdict} |"
    )


def sim_options(args):
    """The options of every simulated DRIVE of the table."""
    sims = os.path.join(args.out, "sim")
    return ["--steps", str(args.steps), "--seed", str(args.seed), "--out", sims, "--quiet"]


def judge(args, log, dataset, csv, declared, cal, label, real_steps, robot, terrain):
    """The twin in `cal/twin/` runs its own DRIVE; `compare` judges it and the declared run
    against the real run's `real_steps` (even or all). Returns the two table rows (or the
    declared row and the twin's failure)."""
    tag = "" if real_steps == "even" else "_all"
    twin = os.path.join(args.out, "sim", f"twin{tag}_{dataset}.mcap")
    failed = run_sim([args.bin, "run", "--robot", os.path.join(cal, "twin", "robot.toml"),
                      "--terrain", os.path.join(cal, "twin", "terrain.toml"), *sim_options(args),
                      "--name", f"twin{tag}_{dataset}"], log, twin)
    cmp_dir = os.path.join(args.out, f"cmp{tag}_{dataset}")
    if not os.path.exists(os.path.join(cmp_dir, "comparison.json")):
        run([args.bin, "compare", csv, declared, *([] if failed else [twin]),
             *(["--real-steps", real_steps] if real_steps != "all" else []),
             "--out", cmp_dir], log)
    with open(os.path.join(cmp_dir, "comparison.json")) as f:
        report = json.load(f)
    judged = f"vs {real_steps} steps"
    models = [f"declared {robot} + {terrain}, {judged}", f"twin ({label}), {judged}"]
    rows = [row(dataset, model, sim) for sim, model in zip(report["sims"], models)]
    if failed:
        rows.append(failed_row(dataset, f"twin ({label})", failed))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", default=os.path.join(REPO, "target", "release", "drive-sim"))
    ap.add_argument("--out", default=os.path.join(REPO, "out", "twin_table"))
    ap.add_argument("--datasets", default=",".join(DATASETS))
    ap.add_argument("--steps", type=int, default=150)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--twin-all", default=None,
                    help="existing all-steps calibrations, a path with {dataset}")
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
        robot, terrain, deployment = declared_models(d)
        # A deployment file is where calibrations start (its effects refit and judged there).
        start = ["--robot", robot] if deployment else []
        sims = os.path.join(args.out, "sim")
        cal = os.path.join(args.out, "cal_odd_" + d)
        declared = os.path.join(sims, f"declared_{d}.mcap")
        if not os.path.exists(declared):
            run([args.bin, "run", "--robot", robot, "--terrain", terrain, *sim_options(args),
                 "--name", f"declared_{d}"], log)
        if not os.path.exists(os.path.join(cal, "twin", "robot.toml")):
            dt = run([args.bin, "calibrate", csv, "--model", "simulator", "--use-steps", "odd",
                      *start, "--out", cal], log)
            print(f"{d}: twin calibration (odd steps) {dt:.0f} s", file=sys.stderr)
        lines += judge(args, log, d, csv, declared, cal, "odd steps", "even", robot, terrain)
        # The twin calibrated on every step, judged against the whole run.
        cal_all = (args.twin_all.format(dataset=d) if args.twin_all
                   else os.path.join(args.out, "cal_all_" + d))
        if not os.path.exists(os.path.join(cal_all, "twin", "robot.toml")):
            if args.twin_all:
                sys.exit(f"error: no twin in {cal_all}")
            dt = run([args.bin, "calibrate", csv, "--model", "simulator", *start, "--no-discovery",
                      "--out", cal_all], log)
            print(f"{d}: twin calibration (all steps) {dt:.0f} s", file=sys.stderr)
        lines += judge(args, log, d, csv, declared, cal_all, "all steps", "all", robot, terrain)
    table = "\n".join(lines)
    print(table)
    with open(os.path.join(args.out, "table.md"), "w") as f:
        f.write(table + "\n")


if __name__ == "__main__":
    main()
