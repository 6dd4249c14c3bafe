#!/usr/bin/env python3
"""The speed loop's memory a twin lacks, added, re-tuned and judged.

For each twin (`DATASET=TWIN_DIR[:HALF]`, a directory with `robot.toml` and `terrain.toml`;
`HALF` odd when the twin was chosen on the odd steps, then it is tuned on the odd steps and
judged on the even ones, else every step for both):
1. `drive-sim judge` of the twin as it is (10 runs, 19 references, seed 0): the loss's p-value
   and how many of its runs `compare` calls "turn memory differs", "step scatter differs" and
   "T/U wheels beyond 5 pp" (against the real run, and the mean over the twin's own runs);
2. `drive-sim tune` from the twin with the speed loop's integral switched on
   (`--inject speed_droop_rad_s_per_knm=D --inject droop_recovery_s=T`, by default 3 rad/s per
   kN·m and 2 s, the values whose run shows the asphalt run's memory, docs/results/twins.md "A
   speed loop that remembers"), re-choosing the motor line, the droop, its recovery time and
   the turning resistance (80 evaluations, the tune's own check on fresh seeds decides whether the choice
   is kept: a twin it does not accept is the start, integral included);
3. `drive-sim judge` of that twin, as in 1.

    python3 scripts/memory_twins.py --out out/memory_twins \\
        warthog_asphalt=out/twin_results/warthog_asphalt/twin ...

(the twins `drive-sim twin` writes: `python3 scripts/twin_results.py`).

Prints a markdown table and writes it to OUT/table.md; every command run is in OUT/commands.txt.
"""
import argparse
import json
import os

from script_common import DEFAULT_BIN, MEASURED, Runner, write_table
TUNED = "motor_torque_speed,speed_droop,droop_recovery,turning_resistance_scale"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("twins", nargs="+", help="DATASET=TWIN_DIR[:odd]")
    ap.add_argument("--out", required=True)
    ap.add_argument("--bin", default=DEFAULT_BIN)
    ap.add_argument("--droop", type=float, default=3.0, help="start droop, rad/s per kN·m")
    ap.add_argument("--recovery", type=float, default=2.0, help="start recovery time, s")
    ap.add_argument("--max-evaluations", type=int, default=80)
    ap.add_argument("--references", type=int, default=19)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    run = Runner(args.out).run

    def judge(real, robot, terrain, judged_on, out):
        run([args.bin, "judge", real, "--robot", robot, "--terrain", terrain, "--real-steps", judged_on,
             "--references", str(args.references), "--seed", str(args.seed), "--out", out])
        j = json.load(open(os.path.join(out, "judge.json")))
        crit = {c["criterion"]: c for c in j["criteria"]}
        n = len(j["sim_seeds"])
        fails = lambda k: f"{crit[k]['real_fails']} of {n} (own {crit[k]['reference_rate'] * n:.1f})"
        return f"{j['loss']['p']:.2f} | {fails('turn_memory')} | {fails('step_scatter')} | {fails('t_area_pct_wheels')}"

    rows = []
    for spec in args.twins:
        dataset, twin = spec.split("=", 1)
        twin, _, half = twin.partition(":")
        chosen_on, judged_on = ("odd", "even") if half == "odd" else ("all", "all")
        real = os.path.join(MEASURED, f"{dataset}.csv")
        out = os.path.join(args.out, f"{dataset}_{chosen_on}")
        robot, terrain = os.path.join(twin, "robot.toml"), os.path.join(twin, "terrain.toml")
        before = judge(real, robot, terrain, judged_on, os.path.join(out, "judge_twin"))
        tdir = os.path.join(out, "tune")
        run([args.bin, "tune", real, "--robot", robot, "--terrain", terrain,
             "--inject", f"speed_droop_rad_s_per_knm={args.droop}", "--inject", f"droop_recovery_s={args.recovery}",
             "--tune", TUNED, "--choose-on", chosen_on, "--max-evaluations", str(args.max_evaluations),
             "--seed", str(args.seed), "--out", tdir])
        t = json.load(open(os.path.join(tdir, "tune.json")))
        value = {p["name"]: (p["chosen"] if t["accepted"] else p["start"]) for p in t["params"]}
        after = judge(real, os.path.join(tdir, "twin", "robot.toml"), os.path.join(tdir, "twin", "terrain.toml"),
                      judged_on, os.path.join(out, "judge_tuned"))
        rows.append(f"| {dataset} | {chosen_on} / {judged_on} | {before} | "
                    f"{value['effect.speed_droop_rad_s_per_knm']:.2f}, {value['effect.droop_recovery_s']:.2f} s"
                    f" ({'accepted' if t['accepted'] else 'start kept'}) | {after} |")
    write_table(args.out, ["dataset", "chosen / judged on", "loss p, twin", "runs whose turn memory differs",
                           "step scatter differs", "T/U wheels differ", "droop (rad/s per kN·m), recovery",
                           "loss p, twin + integral", "turn memory differs", "step scatter differs",
                           "T/U wheels differ"], rows)


if __name__ == "__main__":
    main()
