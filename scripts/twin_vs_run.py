#!/usr/bin/env python3
"""What a twin's own DRIVE run does not share with its robot's run, beyond compare's statistics:
the commands it draws, and how the body moves between a step's two steady windows.

For each measured run with a twin written by `drive-sim twin` (`TWINS/<dataset>/twin/`), it runs
the twin's DRIVE as long as the run (`drive-sim run --robot ... --terrain ... --steps N --seed
S`), analyses both (`drive-sim analyze`) and prints, from the summaries' rows:

- the commands, one per step: quartiles of the larger commanded wheel speed (|rad/s|) and the
  interquartile ranges of the commanded vx (m/s) and wz (rad/s). compare's medians and hulls
  depend on this mix; a twin's runs draw uniformly in U, its robot's run drew as its DRIVE node
  did;
- between a step's steady windows 1 and 2: the median of |Δvx| (m/s; what the calibration's
  noise floor measures) and the mean of Δvx signed by the commanded direction (m/s; negative: the
  body slows once steady), over all the steps the analysis keeps, over those commanded mostly
  straight (|common mode| ≥ |differential mode| of the wheel command) and over the turns (the
  others); the same signed change of the wheels (rad/s); and, for a measured CSV, the same
  signed change of the source's own body-velocity estimate (`ref_vx_m_s`, its smoothed ICP:
  the window's mean), over the same steps, so that a change the project's estimator makes and
  one the lidar odometry carries can be told apart.

    python3 scripts/twin_results.py --out out/twin_results
    python3 scripts/twin_vs_run.py --twins out/twin_results --out out/twin_vs_run

Every command run is in `OUT/commands.txt`, the table in `OUT/table.md`.
"""
import argparse
import collections
import csv
import json
import os
import statistics as st

from script_common import DEFAULT_BIN, MEASURED, Runner, write_table

RUNS = ["warthog_asphalt", "warthog_asphalt_b", "warthog_gravel", "warthog_ice", "husky_2023"]


def step_commands(rows):
    """One (left, right, vx, wz) command per step."""
    seen = {}
    for x in rows:
        if x["cmd_left_rad_s"] is not None:
            seen[x["step"]] = (x["cmd_left_rad_s"], x["cmd_right_rad_s"], x["cmd_vx_m_s"], x["cmd_wz_rad_s"])
    return list(seen.values())


def source_vx(csv_path):
    """The source's own body-velocity estimate, its mean per (step, window), from a measured CSV."""
    sums = collections.defaultdict(lambda: [0.0, 0])
    with open(csv_path) as f:
        for r in csv.DictReader(f):
            if r.get("ref_vx_m_s"):
                acc = sums[(int(r["step"]), int(r["window"]))]
                acc[0] += float(r["ref_vx_m_s"])
                acc[1] += 1
    return {k: v[0] / v[1] for k, v in sums.items()}


def steady_changes(rows, reference=None):
    """Window 1 → 2 of each step kept by the analysis: |Δvx|; Δvx signed by the commanded vx,
    all steps, straight-ish and turns; each side's wheel change signed by its command (sides
    commanded above 1 rad/s); and the source's estimate's signed Δvx when `reference` is given."""
    by = collections.defaultdict(dict)
    for x in rows:
        if x["window"] is not None and not x["excluded"]:
            by[x["step"]][x["window"]] = x
    out = collections.defaultdict(list)
    for step, w in by.items():
        if 1 not in w or 2 not in w:
            continue
        a, b = w[1], w[2]
        sign = 1.0 if a["cmd_vx_m_s"] >= 0 else -1.0
        common = abs(a["cmd_left_rad_s"] + a["cmd_right_rad_s"])
        turn = abs(a["cmd_right_rad_s"] - a["cmd_left_rad_s"]) > common
        d = sign * (b["vx_m_s"] - a["vx_m_s"])
        out["abs"].append(abs(b["vx_m_s"] - a["vx_m_s"]))
        out["signed"].append(d)
        out["turn" if turn else "straight"].append(d)
        if reference is not None and (step, 1) in reference and (step, 2) in reference:
            out["source"].append(sign * (reference[(step, 2)] - reference[(step, 1)]))
        for side in ("left", "right"):
            c = a[f"cmd_{side}_rad_s"]
            if abs(c) > 1.0:
                out["wheel"].append((1.0 if c >= 0 else -1.0) * (b[f"{side}_rad_s"] - a[f"{side}_rad_s"]))
    return out


def describe(summary, reference=None):
    d = json.load(open(summary))["datasets"][0]
    cmds = step_commands(d["rows"])
    wheel = [max(abs(c[0]), abs(c[1])) for c in cmds]
    q = st.quantiles(wheel, n=4)
    iqr = lambda v: st.quantiles(v, n=4)[2] - st.quantiles(v, n=4)[0]
    ch = steady_changes(d["rows"], reference)
    mean = lambda v: f"{st.mean(v):+.3f} ({len(v)})" if v else "-"
    return (
        f"{q[0]:.1f} / {q[1]:.1f} / {q[2]:.1f}",
        f"{iqr([c[2] for c in cmds]):.2f}",
        f"{iqr([c[3] for c in cmds]):.2f}",
        f"{st.median(ch['abs']):.3f}",
        f"{st.mean(ch['signed']):+.3f}",
        mean(ch["straight"]),
        mean(ch["turn"]),
        f"{st.mean(ch['wheel']):+.3f}",
        mean(ch["source"]),
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--twins", required=True, help="the --out of scripts/twin_results.py")
    ap.add_argument("--out", default="out/twin_vs_run")
    ap.add_argument("--bin", default=DEFAULT_BIN)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--datasets", default=",".join(RUNS))
    a = ap.parse_args()
    run = Runner(a.out)
    rows = []
    for name in a.datasets.split(","):
        twin = os.path.join(a.twins, name, "twin")
        if not os.path.isdir(twin):
            continue
        meta = json.load(open(os.path.join(MEASURED, f"{name}.json")))
        terrain = [f for f in sorted(os.listdir(twin)) if f.startswith("terrain")][0]
        runs = os.path.join(a.out, "runs")
        run.run([a.bin, "run", "--robot", os.path.join(twin, "robot.toml"), "--terrain",
                 os.path.join(twin, terrain), "--steps", str(meta["steps"]), "--seed", str(a.seed),
                 "--out", runs, "--name", name])
        csv_path = os.path.join(MEASURED, f"{name}.csv")
        for label, log, reference in (("robot", csv_path, source_vx(csv_path)),
                                      ("twin", os.path.join(runs, f"{name}.mcap"), None)):
            an = os.path.join(a.out, f"analysis_{name}_{label}")
            run.run([a.bin, "analyze", log, "--out", an])
            cells = describe(os.path.join(an, "summary.json"), reference)
            rows.append(f"| {name} | {label} | " + " | ".join(cells) + " |")
    write_table(a.out, ["run", "log", "commanded wheel speed, quartiles (rad/s)", "vx IQR (m/s)",
                        "wz IQR (rad/s)", "steady windows: median abs dvx (m/s)",
                        "mean signed dvx (m/s)", "straight-ish (steps)", "turns (steps)",
                        "mean signed dwheel (rad/s)", "the source's estimate: mean signed dvx (steps)"],
                rows)


if __name__ == "__main__":
    main()
