#!/usr/bin/env python3
"""`drive-sim twin` alone, no recipe, on each measured run, then each asphalt run's twin judged
against the other asphalt run (out of run, with the robot's own difference beside it).

    python3 scripts/twin_results.py [--bin target/release/drive-sim] [--out out/twin_results]
                                    [--datasets warthog_asphalt,...] [--looks 10000,20000,...]

Writes OUT/<dataset>/ (the twin command's files), OUT/out_of_run_<a>_on_<b>/ (judge), the table
to OUT/table.md and every command to OUT/commands.txt; a twin whose twin.json exists is kept
(delete OUT to start over). With --looks, each held-out twin (OUT/<dataset>/held_out/) is judged
again on the even steps with each seed given (OUT/<dataset>/looks/seed_<S>/), and each
out-of-run judgement again with each seed (OUT/out_of_run_<a>_on_<b>/looks/seed_<S>/); the
p-values of those looks beside the command's own go to OUT/held_out_looks.md and
OUT/out_of_run_looks.md: one look's p-value, from 19 references, is a draw.
"""
import argparse
import json
import os
import statistics
import time

from script_common import DEFAULT_BIN, MEASURED, Runner, write_table

DATASETS = ["warthog_asphalt", "warthog_asphalt_b", "warthog_gravel", "warthog_ice", "husky_2023"]
OUT_OF_RUN = [("warthog_asphalt", "warthog_asphalt_b"), ("warthog_asphalt_b", "warthog_asphalt")]


def verdict(j):
    o = j["outcome"]
    word = "indistinguishable" if o["indistinguishable"] else "**distinguishable**"
    flagged = ", ".join(o["flagged"]) or "-"
    return f"{word}, p {o['loss']['p']:.3f}", flagged


def criterion_p(outcome, name):
    return next((c["p"] for c in outcome["criteria"] if c["criterion"] == name), float("nan"))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default=DEFAULT_BIN)
    ap.add_argument("--out", default=os.path.join("out", "twin_results"))
    ap.add_argument("--datasets", default=",".join(DATASETS))
    ap.add_argument("--looks", default="", help="seeds of further judgements of each held-out twin, comma-separated")
    args = ap.parse_args()
    runner = Runner(args.out)
    rows = []
    for d in args.datasets.split(","):
        out = os.path.join(args.out, d)
        if not os.path.exists(os.path.join(out, "twin.json")):
            t0 = time.time()
            runner.run([args.bin, "twin", os.path.join(MEASURED, d + ".csv"), "--out", out])
            print(f"{d}: {time.time() - t0:.0f} s")
        with open(os.path.join(out, "twin.json")) as f:
            r = json.load(f)
        held, held_flags = verdict(r["held_out"]["judgements"][0])
        fin, fin_flags = verdict(r["final"]["judgements"][0])
        final = r["final"]["pass"]
        rounds = [round_text(final["choice"], final["tuning"])]
        if final.get("refinement"):
            rounds.append(round_text(final["refinement"]["choice"], final["refinement"]["tuning"]))
        rows.append(f"| {d} | {held} | {held_flags} | {fin} | {fin_flags} | {'; then '.join(rounds)} | {r['seconds']:.0f} s |")
    write_table(args.out, ["run", "held out (chosen on odd, judged on even)", "flagged", "twin written (all steps, not held out)",
                           "flagged", "tuned (final: first round; then the second, from the tuned twin)", "wall time"], rows)
    oor = []
    for a, b in OUT_OF_RUN:
        out = os.path.join(args.out, f"out_of_run_{a}_on_{b}")
        if not os.path.exists(os.path.join(out, "judge.json")):
            runner.run(out_of_run_judge(args, a, b) + ["--out", out])
        with open(os.path.join(out, "judge.json")) as f:
            o = json.load(f)
        y = o["yardsticks"][0]
        oor.append(f"| twin of {a} | {b} | {'indistinguishable' if o['indistinguishable'] else '**distinguishable**'}, p {o['loss']['p']:.3f} | "
                   f"{criterion_p(o, 'median_rho'):.2f} | {criterion_p(o, 'median_slip_vx'):.2f} | {criterion_p(o, 'median_slip_wz'):.2f} | "
                   f"{o['loss']['real']:.2f} | {y['loss']:.2f} ({'reproduces' if y['reproduces'] else 'differs'}) | "
                   f"{'as close' if y['twin_as_close'] else '**farther**'}, p {y['p_twin_farther']:.3f} |")
    header = ["twin", "judged against", "judge", "p median ρ", "p median slip vx", "p median slip wz",
              "twin's mean loss", "the robot's own other run: loss (compare's verdict)",
              "yardstick test: the twin's runs against the robot's own run"]
    write_table(args.out, header, oor, "out_of_run.md")
    if args.looks:
        looks(runner, args, [int(x) for x in args.looks.split(",")])


def round_text(choice, tuning):
    """A round of the final pass: the knobs it tuned and whether its check accepted them."""
    knobs = ", ".join(choice["chosen"]) or "-"
    if not choice["chosen"]:
        return knobs
    return f"{knobs} ({'accepted' if tuning and tuning['accepted'] else 'not accepted'})"


def out_of_run_judge(args, a, b):
    """The judge command of the twin written from `a` on every step of `b`, with `a` as the
    robot's own other run (the yardstick), without its output directory."""
    twin = os.path.join(args.out, a, "twin")
    return [args.bin, "judge", os.path.join(MEASURED, b + ".csv"), "--robot", os.path.join(twin, "robot.toml"),
            "--terrain", os.path.join(twin, "terrain.toml"), "--other-run", os.path.join(MEASURED, a + ".csv")]


def look_ps(runner, out, seeds, command):
    """The loss's p of each look `command + ["--seed", S, "--out", OUT/looks/seed_S]`, run where
    its judge.json is missing."""
    ps = []
    for seed in seeds:
        look = os.path.join(out, "looks", f"seed_{seed}")
        if not os.path.exists(os.path.join(look, "judge.json")):
            runner.run(command + ["--seed", str(seed), "--out", look])
        with open(os.path.join(look, "judge.json")) as f:
            ps.append(json.load(f)["loss"]["p"])
    return ps


def look_row(label, own, ps):
    """A table row: the command's look, the further looks, how many pass and the median p."""
    every = [own["loss"]["p"]] + ps
    passes = sum(p > own["options"]["alpha"] for p in every)
    return (f"| {label} | {own['loss']['p']:.3f} (seed {own['options']['seed']}) | " + " | ".join(f"{p:.3f}" for p in ps)
            + f" | {passes} of {len(every)} | {statistics.median(every):.3f} |")


def write_looks(args, name, first, rows, seeds):
    header = [first, "the command's judgement"] + [f"seed {s}" for s in seeds] + ["p above 0.05", "median p"]
    write_table(args.out, header, rows, name)


def looks(runner, args, seeds):
    """Each held-out twin judged again on its run's even steps with each of `seeds`, and each
    out-of-run judgement again with each of them."""
    rows = []
    for d in args.datasets.split(","):
        out = os.path.join(args.out, d)
        with open(os.path.join(out, "twin.json")) as f:
            own = json.load(f)["held_out"]["judgements"][0]["outcome"]
        held = os.path.join(out, "held_out")
        command = [args.bin, "judge", os.path.join(MEASURED, d + ".csv"), "--real-steps", "even",
                   "--robot", os.path.join(held, "robot.toml"), "--terrain", os.path.join(held, "terrain.toml")]
        rows.append(look_row(d, own, look_ps(runner, out, seeds, command)))
    write_looks(args, "held_out_looks.md", "run", rows, seeds)
    rows = []
    for a, b in OUT_OF_RUN:
        out = os.path.join(args.out, f"out_of_run_{a}_on_{b}")
        with open(os.path.join(out, "judge.json")) as f:
            own = json.load(f)
        rows.append(look_row(f"twin of {a} on {b}", own, look_ps(runner, out, seeds, out_of_run_judge(args, a, b))))
    write_looks(args, "out_of_run_looks.md", "out of run", rows, seeds)


if __name__ == "__main__":
    main()
