#!/usr/bin/env python3
"""The step scatter a twin lacks, added and judged.

For each twin (`DATASET=TWIN_DIR`, a directory with `robot.toml` and `terrain.toml`):
1. one DRIVE run of the twin (`drive-sim run`, seed 0, as many steps as the real run);
2. `drive-sim compare REAL RUN`: the step scatter of both (`comparison.json`,
   `sims[0].step_scatter`) and, when they differ, the offset to add,
   `sqrt(real^2 - twin^2)`;
3. a copy of the twin with `wheel_speed_scatter_rad_s` at that value (`twin_scatter/`, the
   line commented with where it came from);
4. `drive-sim judge` of both twins on every step (10 runs, 19 references, seed 0): the loss's
   p-value and how many of the twin's runs `compare` calls "step scatter differs" against the
   real run and against the twin's own runs.

The scatter is estimated on every step: the halves of the measured runs hold 1-6 pairs of
steps within 1 rad/s, too few for an estimate, so held-out twins are not done here.

    python3 scripts/scatter_twins.py --out out/scatter_twins \\
        warthog_asphalt=out/twin_results/warthog_asphalt/twin ...

(the twins `drive-sim twin` writes: `python3 scripts/twin_results.py`).

Prints a markdown table and writes it to OUT/table.md; every command run is in OUT/commands.txt.
"""
import argparse
import json
import os

from script_common import DEFAULT_BIN, MEASURED, Runner, write_table


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("twins", nargs="+", help="DATASET=TWIN_DIR")
    ap.add_argument("--out", required=True)
    ap.add_argument("--bin", default=DEFAULT_BIN)
    ap.add_argument("--references", type=int, default=19)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    run = Runner(args.out).run

    rows = []
    for spec in args.twins:
        dataset, twin = spec.split("=", 1)
        real = os.path.join(MEASURED, f"{dataset}.csv")
        out = os.path.join(args.out, dataset)
        robot, terrain = os.path.join(twin, "robot.toml"), os.path.join(twin, "terrain.toml")
        run([args.bin, "run", "--robot", robot, "--terrain", terrain, "--steps", "100", "--seed", "0",
             "--out", os.path.join(out, "run"), "--name", "twin", "--quiet", "--force"])
        run([args.bin, "compare", real, os.path.join(out, "run", "twin.mcap"), "--out", os.path.join(out, "compare")])
        d = json.load(open(os.path.join(out, "compare", "comparison.json")))["sims"][0]["step_scatter"]
        judged = {"before": (robot, terrain)}
        sigma = d["offset_to_add_rad_s"] if d["differs"] else None
        if sigma is not None:
            sdir = os.path.join(out, "twin_scatter")
            os.makedirs(sdir, exist_ok=True)
            text = open(robot).read()
            ci = lambda s: f"{s['wheel_rad_s']:.3f} [{s['ci95']['lower']:.3f}, {s['ci95']['upper']:.3f}]"
            line = (f"wheel_speed_scatter_rad_s = {sigma!r}  # [compare] {dataset}: step scatter real {ci(d['real'])}, "
                    f"twin {ci(d['sim'])} rad/s per wheel (one run, seed 0): sqrt(real^2 - twin^2); scripts/scatter_twins.py\n")
            text = text.replace("[effects]\n", "[effects]\n" + line, 1) if "[effects]\n" in text else text.rstrip("\n") + "\n\n[effects]\n" + line
            open(os.path.join(sdir, "robot.toml"), "w").write(text)
            open(os.path.join(sdir, "terrain.toml"), "w").write(open(terrain).read())
            judged["after"] = (os.path.join(sdir, "robot.toml"), os.path.join(sdir, "terrain.toml"))
        res = {}
        for k, (r, t) in judged.items():
            jdir = os.path.join(out, f"judge_{k}")
            run([args.bin, "judge", real, "--robot", r, "--terrain", t, "--references", str(args.references),
                 "--seed", str(args.seed), "--out", jdir])
            j = json.load(open(os.path.join(jdir, "judge.json")))
            c = next(c for c in j["criteria"] if c["criterion"] == "step_scatter")
            res[k] = (j["loss"]["p"], c["real_fails"], c["reference_rate"] * len(j["sim_seeds"]), len(j["sim_seeds"]))
        fmt = lambda s: f"{s['wheel_rad_s']:.2f} [{s['ci95']['lower']:.2f}, {s['ci95']['upper']:.2f}]" if s["wheel_rad_s"] is not None else "-"
        cell = lambda k: (f"{res[k][0]:.2f} | {res[k][1]} of {res[k][3]} (own runs {res[k][2]:.1f})" if k in res else "- | -")
        rows.append(f"| {dataset} | {fmt(d['real'])} | {fmt(d['sim'])} | "
                    f"{'%.2f' % sigma if sigma is not None else 'none (alike)'} | {cell('before')} | {cell('after')} |")
    write_table(args.out, ["dataset", "step scatter, real (rad/s per wheel, 95 %)", "twin's run",
                           "wheel_speed_scatter_rad_s added", "loss p, twin", "runs whose step scatter differs, twin",
                           "loss p, twin + scatter", "the same, twin + scatter"], rows)


if __name__ == "__main__":
    main()
