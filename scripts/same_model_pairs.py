#!/usr/bin/env python3
"""How often `compare`'s verdict calls two runs of the *same* model different.

For each terrain, the declared Warthog runs DRIVE with seeds 0-5 (100 steps; each seed is also a
new realisation of the terrain's roughness and of the sensor noise), and `drive-sim compare`
judges seed 1 against seed 0, 3 against 2, 5 against 4, as it would a twin against a real run.
A perfect twin can do no better than this: every "differs" here is a false rejection of a model
that is exactly right.

    python3 scripts/same_model_pairs.py [--bin target/release/drive-sim] [--out out/same_model_pairs]
                                        [--terrains asphalt,gravel,ice] [--steps 100]
                                        [--tf-smoother kernel|local-linear] [--pairs 3]
                                        [--yardstick-splits K]

`--pairs N` judges seeds 1 vs 0, 3 vs 2, ... up to 2N-1 vs 2N-2 (the same seeds on every terrain,
so the terrains' rows share their commands). `--yardstick-splits K` is passed to `compare` (its
default when absent; 1 is the yardstick of one odd/even split).

Prints a Markdown table (OUT/table.md) and a count of the verdicts; runs and comparisons that
exist are reused.
"""

import argparse
import json
import os
import subprocess

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default=os.path.join(REPO, "target", "release", "drive-sim"))
    ap.add_argument("--out", default=os.path.join(REPO, "out", "same_model_pairs"))
    ap.add_argument("--terrains", default="asphalt,gravel,ice")
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--tf-smoother", default="kernel", help="compare's smoother of the maps")
    ap.add_argument("--pairs", type=int, default=3, help="pairs of seeds per terrain")
    ap.add_argument("--yardstick-splits", type=int, default=None,
                    help="compare's --yardstick-splits (its default when absent)")
    args = ap.parse_args()
    lines = [
        "| terrain | seeds | significant (Holm) | T/U areas beyond 5 pp | TF RMS / yardstick (vx, vy, wz, left, right) "
        "| beyond 1.5× | maps' permutation p (Holm) | maps differing (permutation) | loss | verdict |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    counts = {"pairs": 0, "reproduces": 0, "yardstick": 0, "permutation": 0, "metrics": 0, "areas": 0}
    losses = []
    for t in args.terrains.split(","):
        runs = os.path.join(args.out, t)
        for s in range(2 * args.pairs):
            mcap = os.path.join(runs, f"warthog_{t}_s{s}.mcap")
            if not os.path.exists(mcap):
                subprocess.run([args.bin, "run", "--robot", "warthog", "--terrain", t, "--steps", str(args.steps),
                                "--seed", str(s), "--out", runs, "--quiet"], check=True,
                               stdout=subprocess.DEVNULL)
        for a in range(0, 2 * args.pairs, 2):
            b = a + 1
            out = os.path.join(args.out, f"compare_{t}_{a}_{b}{suffix(args)}")
            path = os.path.join(out, "comparison.json")
            if not os.path.exists(path):
                extra = [] if args.yardstick_splits is None else ["--yardstick-splits", str(args.yardstick_splits)]
                subprocess.run([args.bin, "compare", os.path.join(runs, f"warthog_{t}_s{a}.mcap"),
                                os.path.join(runs, f"warthog_{t}_s{b}.mcap"), "--out", out,
                                "--tf-smoother", args.tf_smoother] + extra, check=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            with open(path) as f:
                c = json.load(f)["sims"][0]
            v = c["verdict"]
            counts["pairs"] += 1
            counts["reproduces"] += v["reproduces"]
            counts["yardstick"] += bool(v["tf_beyond_yardstick"])
            counts["permutation"] += bool(v.get("tf_significant"))
            counts["metrics"] += bool(v["significant"])
            counts["areas"] += bool(v["areas_beyond_tolerance"])
            short = lambda xs: ", ".join(x.replace("slip_", "").split("_")[0] if x.startswith("slip_") else x
                                         for x in xs) or "-"
            ratios = ", ".join("%.2f" % x["ratio"] for x in c["transfer"])
            ps = ", ".join("%.3f" % x["p_permutation_holm"] for x in c["transfer"])
            verdict = "reproduces" if v["reproduces"] else "differs"
            # compare's loss (what `drive-sim tune` minimises); a comparison.json without one is
            # reused as it is and shows "-": delete it to recompute.
            loss = (c.get("loss") or {}).get("total")
            if loss is not None:
                losses.append(loss)
            lines.append(
                f"| {t} | {b} vs {a} | {short(v['significant'])} | {short(v['areas_beyond_tolerance'])} | "
                f"{ratios} | {short(v['tf_beyond_yardstick'])} | {ps} | {short(v.get('tf_significant', []))} | "
                f"{'%.1f' % loss if loss is not None else '-'} | {verdict} |")
    lines.append("")
    lines.append(
        f"{counts['pairs']} pairs of runs of one model: {counts['reproduces']} 'reproduces'; "
        f"a map beyond 1.5× its yardstick in {counts['yardstick']}, a map differing by the permutation "
        f"test in {counts['permutation']}, a metric significant in {counts['metrics']}, an area beyond "
        f"5 pp in {counts['areas']}." + (
            f" Loss {min(losses):.1f}-{max(losses):.1f}, mean {sum(losses) / len(losses):.1f}." if losses else ""))
    table = "\n".join(lines)
    print(table)
    os.makedirs(args.out, exist_ok=True)
    name = f"table{suffix(args)}.md"
    with open(os.path.join(args.out, name), "w") as f:
        f.write(table + "\n")


def suffix(args):
    """Output names of a non-default smoother or yardstick (the default's have none)."""
    s = "" if args.tf_smoother == "kernel" else "_" + args.tf_smoother
    return s + ("" if args.yardstick_splits is None else f"_ys{args.yardstick_splits}")


if __name__ == "__main__":
    main()
