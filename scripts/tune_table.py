#!/usr/bin/env python3
"""Twins tuned in closed loop (`drive-sim tune`), chosen on each measured run's odd steps and
judged on its even steps, beside the models they start from.

For each dataset, two starts:
- the declared robot and terrain (the run's deployment file `robots/<dataset>.toml` when there
  is one, as `scripts/twin_table.py` takes it);
- the twin calibrated by replay on the odd steps (`drive-sim calibrate --model simulator
  --use-steps odd --no-discovery`),
each tuned with `drive-sim tune --choose-on odd` on the effects of `WARTHOG[recipe]` or `HUSKY`, and
judged by `tune` itself on the even steps with three fresh seeds. A first row per dataset
compares the real odd steps themselves with the even ones: the closest any model that matches
the odd steps can come.

A second table does the same on every step (a twin against the run it was made from): the twin
calibrated by replay on all steps, tuned with `--choose-on all`, both
judged by `tune` on all steps with three fresh seeds (not held out). The table gives, per start and
per model (start, tuned), the means over the three judging seeds: median ρ difference, T/U
areas (sim − real, percentage points), transfer-function RMS over the yardstick, and in how
many of the seeds compare's verdict is "reproduces".

    python3 scripts/tune_table.py [--bin target/release/drive-sim] [--out out/tune_table]
                                  [--datasets warthog_asphalt,...] [--tf-smoother kernel|local-linear]
                                  [--warthog line|droop|clamp]

Writes OUT/table.md and every command to OUT/commands.txt; a stage whose output exists is
skipped (delete OUT to start over).
"""

import argparse
import json
import os

# The declared models of a dataset and the logged command runner are the twin table's.
from twin_table import DATA, DATASETS, REPO, declared_models, run

# What each robot's twins tune, and the options of `tune` that go with it. For the Warthog
# (`--warthog line`, the default): the motor's torque-speed line *instead of* the
# wheel-speed clamp (switched off), because on asphalt and gravel the fast wheel's steady speed
# falls from ~13 rad/s driving straight to ~10.5 rad/s pivoting about a nearly stopped side,
# while on ice, where nothing loads it, it stays at ~13 whatever the turn (README, "A ceiling
# that falls with the load"), which a clamp cannot do and a line does; the lateral (turning)
# friction scale; and the centripetal slip, which lets the twin's side slip in turns differ from
# what its turning friction implies. `--warthog droop` adds the speed loop's droop, because on
# asphalt and gravel the slower wheel of a curve runs faster than commanded and the faster one
# slower, where on ice both track (README, "A speed loop that gives way"). `--warthog clamp`
# tunes the line, the lateral scale and the clamp. For the Husky as its run was configured
# (robots/husky_2023.toml), the wheel-speed
# limit its file declares, its velocity controller's yaw-rate limit, and the rolling-radius
# scale its replay calibrations select (0.75-0.78: with the limit it caps the straight-line
# speed at 0.7 m/s where the run reaches 0.96 m/s, a stand-in the closed loop judges).
WARTHOG = {
    "line": ("motor_torque_speed,turning_resistance_scale,centripetal_slip",
             ["--inject", "wheel_speed_saturation_rad_s=0", "--max-evaluations", "60"]),
    "droop": ("motor_torque_speed,turning_resistance_scale,centripetal_slip,speed_droop",
              ["--inject", "wheel_speed_saturation_rad_s=0", "--max-evaluations", "80"]),
    "clamp": ("motor_torque_speed,turning_resistance_scale,wheel_speed_saturation_rad_s", []),
}
HUSKY = ("wheel_radius_scale,wheel_speed_saturation_rad_s,command_yaw_rate_limit_rad_s", [])


def tune_for(robot, warthog_recipe):
    """What `tune` tunes for a dataset of `robot`, and its extra options."""
    return WARTHOG[warthog_recipe] if robot == "warthog" else HUSKY


def robot_name(dataset):
    with open(os.path.join(DATA, dataset + ".json")) as f:
        return json.load(f)["robot"]


def tuned_label(o):
    """The tuned row's label: the chosen values, whether the check accepted them, the loss."""
    chosen = ", ".join(f"{p['name'].split('.')[-1]} {p['chosen']:.3g}" for p in o["params"])
    verdict = "accepted" if o["accepted"] else "not accepted"
    return f"→ tuned ({chosen}; {verdict}, loss {o['start_loss']:.1f} → {o['chosen_loss']:.1f})"


def mean(xs):
    xs = [x for x in xs if x is not None]
    return sum(xs) / len(xs) if xs else float("nan")


def summary(runs):
    """Means over the judging seeds of one model's held-out comparisons."""
    ok = [r for r in runs if r.get("verdict")]
    m = lambda r, k: next(x for x in r["metrics"] if x["metric"] == k)
    tf = [mean([r["transfer"][i]["ratio"] for r in ok]) for i in range(5)] if ok else []
    return {
        "rho": mean([m(r, "median_rho")["difference"] for r in ok]),
        "rho_real": m(ok[0], "median_rho")["real"] if ok else float("nan"),
        "rho_sim": mean([m(r, "median_rho")["sim"] for r in ok]),
        "tub": mean([m(r, "t_area_pct_body")["difference"] for r in ok]),
        "tuw": mean([m(r, "t_area_pct_wheels")["difference"] for r in ok]),
        "tf": tf,
        "reproduces": sum(1 for r in ok if r["verdict"]["reproduces"]),
        "fails": sorted({f for r in ok for f in r["verdict"]["significant"]
                         + [a + " > 5 pp" for a in r["verdict"]["areas_beyond_tolerance"]]
                         + [t.replace("slip_", "").split("_")[0] + " map" for t in r["verdict"]["tf_beyond_yardstick"]]}),
        "n": len(runs),
        "failed_runs": len(runs) - len(ok),
    }


def row(dataset, label, s):
    tf = ", ".join(f"{x:.2f}" for x in s["tf"])
    failed = f" ({s['failed_runs']} runs failed)" if s["failed_runs"] else ""
    fails = ", ".join(s["fails"]) or "-"
    return (f"| {dataset} | {label} | {s['rho_sim']:.3f} (real {s['rho_real']:.3f}) | {s['rho']:+.3f} | "
            f"{s['tub']:+.1f} pp | {s['tuw']:+.1f} pp | {tf} | {s['reproduces']} of {s['n']}{failed} | {fails} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default=os.path.join(REPO, "target", "release", "drive-sim"))
    ap.add_argument("--out", default=os.path.join(REPO, "out", "tune_table"))
    ap.add_argument("--datasets", default=",".join(DATASETS))
    ap.add_argument("--tf-smoother", default="kernel", help="the maps' smoother in tune's loss and judgement")
    ap.add_argument("--warthog", default="line", choices=list(WARTHOG),
                    help="what the Warthog's twins tune (see WARTHOG)")
    ap.add_argument("--start-from", default=None, metavar="TABLE",
                    help="start each tune from the twin the same tune of another table chose "
                         "(TABLE/<dataset>/tune_<k>/twin): a recipe that nests that table's starts "
                         "from its optimum (its first point), not from the middle of the box")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    data = lambda d: os.path.join(DATA, d + ".csv")
    lines = [
        "| dataset | model (judged on the even steps, 3 seeds) | median ρ | ρ difference | T/U body | "
        "T/U wheels | TF RMS / yardstick (vx, vy, wz, left, right) | reproduces | what fails (any seed) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    all_lines = lines[:2]
    all_lines[0] = all_lines[0].replace("judged on the even steps, 3 seeds", "judged on all steps, 3 fresh seeds")
    with open(os.path.join(args.out, "commands.txt"), "a") as log:
        for d in args.datasets.split(","):
            robot, terrain, _ = declared_models(d)
            tune, tune_opts = tune_for(robot_name(d), args.warthog)
            cal = os.path.join(args.out, d, "calibrate_odd")
            if args.start_from:
                cal = os.path.join(args.start_from, d, "calibrate_odd")
            elif not os.path.exists(os.path.join(cal, "twin", "robot.toml")):
                s = run([args.bin, "calibrate", data(d), "--model", "simulator", "--use-steps", "odd",
                         "--no-discovery", "--robot", robot, "--terrain", terrain, "--out", cal], log)
                print(f"{d}: odd-step calibration {s:.0f} s")
            starts = [
                ("declared", robot, terrain),
                ("replay twin (odd steps)", os.path.join(cal, "twin", "robot.toml"),
                 os.path.join(cal, "twin", "terrain.toml")),
            ]
            if args.start_from:
                twin = lambda k: os.path.join(args.start_from, d, k, "twin")
                starts = [(f"{label} → tuned ({os.path.basename(os.path.normpath(args.start_from))})",
                           os.path.join(twin(f"tune_{i}"), "robot.toml"), os.path.join(twin(f"tune_{i}"), "terrain.toml"))
                          for i, (label, _, _) in enumerate(starts)]
            for i, (label, r, t) in enumerate(starts):
                out = os.path.join(args.out, d, f"tune_{i}")
                if not os.path.exists(os.path.join(out, "tune.json")):
                    s = run([args.bin, "tune", data(d), "--robot", r, "--terrain", t, "--tune", tune,
                             "--choose-on", "odd", "--tf-smoother", args.tf_smoother, "--out", out] + tune_opts, log)
                    print(f"{d}: tune from {label} {s:.0f} s")
                with open(os.path.join(out, "tune.json")) as f:
                    o = json.load(f)
                if i == 0:
                    lines.append(row(d, "the real odd steps themselves (a model matching them exactly)",
                                     summary([o["heldout"]["real_halves"]])))
                lines.append(row(d, label, summary(o["heldout"]["start"])))
                lines.append(row(d, tuned_label(o), summary(o["heldout"]["chosen"])))
            # Every step: calibrated, tuned and judged on the whole run.
            cal_all = os.path.join(args.out, d, "calibrate_all")
            start_all = os.path.join(cal_all, "twin")
            if args.start_from:
                start_all = os.path.join(args.start_from, d, "tune_all", "twin")
            elif not os.path.exists(os.path.join(cal_all, "twin", "robot.toml")):
                s = run([args.bin, "calibrate", data(d), "--model", "simulator", "--no-discovery",
                         "--robot", robot, "--terrain", terrain, "--out", cal_all], log)
                print(f"{d}: all-steps calibration {s:.0f} s")
            out = os.path.join(args.out, d, "tune_all")
            if not os.path.exists(os.path.join(out, "tune.json")):
                s = run([args.bin, "tune", data(d), "--robot", os.path.join(start_all, "robot.toml"),
                         "--terrain", os.path.join(start_all, "terrain.toml"), "--tune", tune,
                         "--choose-on", "all", "--tf-smoother", args.tf_smoother, "--out", out] + tune_opts, log)
                print(f"{d}: tune on all steps {s:.0f} s")
            with open(os.path.join(out, "tune.json")) as f:
                o = json.load(f)
            all_lines.append(row(d, "replay twin (all steps)" + (" → tuned (start)" if args.start_from else ""),
                                 summary(o["same_steps"]["start"])))
            all_lines.append(row(d, tuned_label(o), summary(o["same_steps"]["chosen"])))
    table = "\n".join(lines + ["", "Every step (chosen and judged on the same steps, fresh seeds; not held out):", ""]
                      + all_lines)
    print(table)
    with open(os.path.join(args.out, "table.md"), "w") as f:
        f.write(table + "\n")


if __name__ == "__main__":
    main()
