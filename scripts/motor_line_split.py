#!/usr/bin/env python3
"""The motor's torque-speed line chosen on one half of a measured run, judged on the other.

Replays cannot tell the line's stall torque from its no-load speed (README, "Twins and
compare"); the closed-loop statistics can. This script chooses the line (stall torque, no-load
speed) and the lateral-friction scale by a grid search on what `drive-sim compare` says against
the run's **odd** steps, then reports the chosen model, and the declared one, against the
**even** steps, which played no part in the choice:

- each grid point runs the declared robot's DRIVE (150 steps, seed 0) with the line injected
  (the declared wheel-speed limit switched off: the line's no-load speed is the ceiling) and is
  compared with the odd steps;
- its loss is the sum of (difference / half-width of its 95 % interval)² over compare's eight
  metrics (median ρ, the five median slips, both T/U areas), plus the sum of the squared
  transfer-function ratios (RMS over the split-half yardstick), five channels;
- the grid point of least loss is run against the even steps, beside the declared model.

    python3 scripts/motor_line_split.py [--bin target/release/drive-sim] [--out out/motor_line_split]
                                        [--dataset warthog_asphalt] [--seed 0]

Prints the grid's best points and a Markdown table of the held-out judgement; writes the table
to OUT/table.md and every command to OUT/commands.txt. Outputs that exist are reused.
"""

import argparse
import itertools
import json
import os
import shlex
import subprocess

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
DATA = os.path.join(REPO, "..", "shared", "data", "measured")

STALL_NM = [900, 1100, 1300, 1500, 1700, 2000]
NO_LOAD_RAD_S = [13.0, 14.0, 15.0]
LATERAL_SCALE = [0.7, 0.8, 0.9, 1.0]


def run(cmd, log):
    log.write(" ".join(shlex.quote(c) for c in cmd) + "\n")
    log.flush()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def simulate(args, name, injects, log):
    mcap = os.path.join(args.out, "sim", name + ".mcap")
    if not os.path.exists(mcap):
        cmd = [args.bin, "run", "--robot", "warthog", "--terrain", "asphalt", "--steps", "150",
               "--seed", str(args.seed), "--out", os.path.join(args.out, "sim"), "--name", name,
               "--quiet"]
        for k, v in injects:
            cmd += ["--inject", f"{k}={v}"]
        run(cmd, log)
    return mcap


def compare(args, mcap, half, name, log):
    out = os.path.join(args.out, f"cmp_{half}_{name}")
    path = os.path.join(out, "comparison.json")
    if not os.path.exists(path):
        run([args.bin, "compare", os.path.join(DATA, args.dataset + ".csv"), mcap,
             "--real-steps", half, "--out", out], log)
    with open(path) as f:
        return json.load(f)["sims"][0]


def loss(c):
    total = 0.0
    for m in c["metrics"]:
        ci = m["difference_ci95"]
        half_width = (ci["upper"] - ci["lower"]) / 2 if ci else float("inf")
        if half_width > 0:
            total += (m["difference"] / half_width) ** 2
    return total + sum(t["ratio"] ** 2 for t in c["transfer"] if t["points"] > 0)


def row(label, c):
    m = {x["metric"]: x for x in c["metrics"]}
    rho = m["median_rho"]
    ci = rho["difference_ci95"]
    tu_b, tu_w = m["t_area_pct_body"], m["t_area_pct_wheels"]
    tf = ", ".join(f"{t['ratio']:.2f}" for t in c["transfer"])
    v = c["verdict"]
    why = "; ".join(
        part for part in [
            "significant: " + ", ".join(v["significant"]) if v["significant"] else "",
            "area > 5 pp: " + ", ".join(v["areas_beyond_tolerance"]) if v["areas_beyond_tolerance"] else "",
            "TF > 1.5×: " + ", ".join(t.replace("slip_", "").split("_")[0] for t in v["tf_beyond_yardstick"])
            if v["tf_beyond_yardstick"] else "",
        ] if part
    )
    return (f"| {label} | {rho['sim']:.3f} (real {rho['real']:.3f}) | {rho['difference']:+.3f} "
            f"[{ci['lower']:+.3f}, {ci['upper']:+.3f}] | {tu_b['difference']:+.1f} pp | "
            f"{tu_w['difference']:+.1f} pp | {tf} | "
            f"{'reproduces' if v['reproduces'] else 'differs (' + why + ')'} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default=os.path.join(REPO, "target", "release", "drive-sim"))
    ap.add_argument("--out", default=os.path.join(REPO, "out", "motor_line_split"))
    ap.add_argument("--dataset", default="warthog_asphalt")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "commands.txt"), "a") as log:
        scored = []
        for stall, no_load, lateral in itertools.product(STALL_NM, NO_LOAD_RAD_S, LATERAL_SCALE):
            name = f"line_{stall}_{no_load:g}_{lateral:g}"
            injects = [("wheel_speed_saturation_rad_s", 0), ("motor_stall_torque_nm", stall),
                       ("motor_no_load_speed_rad_s", no_load), ("turning_resistance_scale", lateral)]
            mcap = simulate(args, name, injects, log)
            scored.append((loss(compare(args, mcap, "odd", name, log)), name, mcap))
        scored.sort()
        print("best on the odd steps (loss, model):")
        for s, name, _ in scored[:5]:
            print(f"  {s:8.2f}  {name}")
        declared = simulate(args, "declared", [], log)
        best_loss, best_name, best_mcap = scored[0]
        odd_declared = loss(compare(args, declared, "odd", "declared", log))
        lines = [
            f"Chosen on the odd steps of {args.dataset}: {best_name} (loss {best_loss:.2f}; "
            f"the declared model's {odd_declared:.2f}); judged on the even steps:",
            "",
            "| model | median ρ | ρ difference [95 %] | T/U body | T/U wheels | TF RMS / yardstick "
            "(vx, vy, wz, left, right) | verdict |",
            "|---|---|---|---|---|---|---|",
            row("declared warthog + asphalt", compare(args, declared, "even", "declared", log)),
            row(f"motor line {best_name[5:].replace('_', ' / ')}",
                compare(args, best_mcap, "even", best_name, log)),
        ]
    table = "\n".join(lines)
    print(table)
    with open(os.path.join(args.out, "table.md"), "w") as f:
        f.write(table + "\n")


if __name__ == "__main__":
    main()
