#!/usr/bin/env python3
"""Can `compare` tell each measured run from its twins? `drive-sim judge` on every model of the
tune tables.

For each dataset, `drive-sim judge` (10 runs of the model, 19 reference runs of its own, a Monte
Carlo test; see `src/experiments/judge/mod.rs`) on:
- the declared robot and terrain, against every step and against the even steps (what a half
  run can tell apart);
- the twin calibrated by replay on all steps, against every step, and the one calibrated on the
  odd steps, against the even steps (held out);
- for each tune table given (`--tables NAME=DIR,...`, the outputs of `scripts/tune_table.py`):
  its twin tuned on all steps (`tune_all`, against every step), and its two twins tuned on the
  odd steps (`tune_0` from the declared model, `tune_1` from the odd-step replay twin), against
  the even steps.

Where several tables tuned the same start on the same steps (the recipes), the row whose twin has
the lowest *choosing* loss (`tune.json` `chosen_loss` when the check accepted the choice, else
`start_loss`: on the choosing steps and seeds only) is marked: that is the twin a user would
pick without looking at the judged steps.

    python3 scripts/judge_table.py --tables line=out/tune_table_line,droop=out/tune_table_droop
                                   [--bin target/release/drive-sim] [--out out/judge_table]
                                   [--datasets warthog_asphalt,...] [--sims 10] [--references 19]
                                   [--seed S] [--picked-only]

`--picked-only` judges only the marked twins (and the Husky's tuned ones): with another `--seed`
and more `--references`, a second look at the same twins with runs the first never drew.

The calibrations and the Husky's tunes are read from the first table. Writes OUT/table.md and
every command to OUT/commands.txt; a judgement whose output exists is reused.
"""

import argparse
import json
import os

from twin_table import DATA, DATASETS, REPO, declared_models, run


def short(criterion):
    """`slip_vx_m_s map` -> `vx map`, `median_slip_wz` -> `slip wz`, `t_area_pct_body` -> `T/U body`."""
    if criterion.endswith(" map"):
        return criterion.replace("slip_", "").replace("_m_s", "").replace("_rad_s", "")
    if criterion.startswith("t_area_pct_"):
        return "T/U " + criterion[len("t_area_pct_"):]
    return criterion.replace("median_slip_", "slip ").replace("median_", "")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default=os.path.join(REPO, "target", "release", "drive-sim"))
    ap.add_argument("--out", default=os.path.join(REPO, "out", "judge_table"))
    ap.add_argument("--datasets", default=",".join(DATASETS))
    ap.add_argument("--tables", required=True, help="NAME=DIR,... tune_table.py outputs")
    ap.add_argument("--sims", type=int, default=10)
    ap.add_argument("--references", type=int, default=19)
    ap.add_argument("--seed", type=int, default=0, help="judge's first seed")
    ap.add_argument("--picked-only", action="store_true",
                    help="only the twins the choosing loss picks (the marked rows): a second look with other seeds")
    args = ap.parse_args()
    tables = [t.split("=", 1) for t in args.tables.split(",")]
    os.makedirs(args.out, exist_ok=True)
    log = open(os.path.join(args.out, "commands.txt"), "a")
    lines = [
        "| dataset | model | judged on | choosing loss | runs called \"differs\" against the real run | against the model's own runs (mean, range) "
        "| p (loss: decides) | p (runs called \"differs\") | compare can tell them apart | flagged (own p ≤ 0.05, uncorrected) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for d in args.datasets.split(","):
        robot, terrain, _ = declared_models(d)
        first = os.path.join(tables[0][1], d)
        # (slug, label, robot, terrain, judged steps, (tune, choosing loss) of a tuned twin)
        # The declared model against the even steps too: how much a half run can tell apart.
        models = [("declared", "declared", robot, terrain, "all", None),
                  ("declared_even", "declared", robot, terrain, "even", None)]
        for cal, steps in (("calibrate_all", "all"), ("calibrate_odd", "even")):
            twin = os.path.join(first, cal, "twin")
            label = "replay twin (all steps)" if steps == "all" else "replay twin (odd steps)"
            models.append((cal, label, os.path.join(twin, "robot.toml"), os.path.join(twin, "terrain.toml"), steps, None))
        husky = d.startswith("husky")
        for tune, steps, start in (("tune_all", "all", "replay twin (all steps)"), ("tune_0", "even", "declared"),
                                   ("tune_1", "even", "replay twin (odd steps)")):
            for name, tdir in (tables[:1] if husky else tables):
                twin = os.path.join(tdir, d, tune, "twin")
                with open(os.path.join(tdir, d, tune, "tune.json")) as f:
                    t = json.load(f)
                recipe = "" if husky else f" ({name})"
                label = f"{start} → tuned{recipe}{'' if t['accepted'] else ', not accepted'}"
                # The twin's own choosing loss: the search's best when the check accepted it,
                # else the start's (the twin is then the start).
                loss = t["chosen_loss"] if t["accepted"] else t["start_loss"]
                models.append((tune if husky else f"{tune}_{name}", label, os.path.join(twin, "robot.toml"),
                               os.path.join(twin, "terrain.toml"), steps, (tune, loss)))
        # The recipe the choosing loss picks, per start and steps.
        best = {}
        for m in models:
            if m[5]:
                best[m[5][0]] = min(best.get(m[5][0], float("inf")), m[5][1])
        for slug, label, r, t, steps, chosen in models:
            picked = chosen and (husky or chosen[1] == best[chosen[0]])
            if args.picked_only and not picked:
                continue
            out = os.path.join(args.out, d, slug)
            path = os.path.join(out, "judge.json")
            if not os.path.exists(path):
                run([args.bin, "judge", os.path.join(DATA, d + ".csv"), "--robot", r, "--terrain", t,
                     "--real-steps", steps, "--sims", str(args.sims), "--references", str(args.references),
                     "--seed", str(args.seed),
                     "--out", out], log)
            with open(path) as f:
                j = json.load(f)
            v = j["criteria"][0]
            n = len(j["sim_seeds"])
            fails = [c["reference_fails"] for c in j["criteria"]][0]
            mark = " ★" if picked and not husky else ""
            lines.append(
                f"| {d} | {label}{mark} | {steps} | {f'{chosen[1]:.2f}' if chosen else '-'} | {v['real_fails']} of {n} | "
                f"{v['reference_rate'] * n:.1f} ({min(fails)}–{max(fails)}) | {j['loss']['p']:.3f} | {v['p']:.3f} | "
                f"{'no' if j['indistinguishable'] else '**yes**'} | {', '.join(short(c) for c in j['flagged']) or '-'} |")
            print(lines[-1], flush=True)
    table = "\n".join(lines) + "\n"
    with open(os.path.join(args.out, "table.md"), "w") as f:
        f.write(table)
    print(table)


if __name__ == "__main__":
    main()
