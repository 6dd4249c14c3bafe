#!/usr/bin/env python3
"""Which cells each measured run's commands were drawn in, its median slips turn by turn, and its ρ.

A run's medians (ρ, the slips) are medians over its steps, and a skid-steering robot's yaw slip
changes sign with the turn: a run that drew more right turns than left ones has the right
turns' median, whatever the robot. This script runs `drive-sim analyze` on each measured run
and prints, from its summary (`command_mix`, and the rows of the steady windows the analysis
keeps):

- the steps per quadrant and the fair-coin p-value of the left turns' count (what `analyze`
  prints as "commands drawn");
- the median yaw slip along the command (rad/s, the analysis's sign) over all the steady
  windows, over the left turns' (commanded wz > 0) and over the right turns';
- the steps whose wheels turn opposite ways (pivots, turns in place), the run's median ρ over
  its steps, and how many of those steps have a ρ at or above it (a second table).

    python3 scripts/command_mix.py --out out/command_mix

Every command run is in `OUT/commands.txt`, the table in `OUT/table.md`.
"""
import argparse
import json
import os
import statistics as st

from script_common import DEFAULT_BIN, MEASURED, Runner, write_table

RUNS = ["warthog_asphalt", "warthog_asphalt_b", "warthog_gravel", "warthog_ice", "husky_2023"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", default=DEFAULT_BIN, help="the drive-sim binary")
    ap.add_argument("--out", default="out/command_mix", help="output directory")
    args = ap.parse_args()
    runner = Runner(args.out)
    rows = []
    rho_rows = []
    for run in RUNS:
        out = os.path.join(args.out, run)
        runner.run([args.bin, "analyze", os.path.join(MEASURED, run + ".csv"), "--out", out])
        with open(os.path.join(out, "summary.json")) as f:
            d = json.load(f)["datasets"][0]
        m = d["command_mix"]
        kept = [r for r in d["rows"] if not r["excluded"] and r["window"] in (1, 2)]
        left = [r["slip_wz_rad_s"] for r in kept if r["cmd_wz_rad_s"] > 0]
        right = [r["slip_wz_rad_s"] for r in kept if r["cmd_wz_rad_s"] < 0]
        steps = m["forward_left"] + m["forward_right"] + m["backward_left"] + m["backward_right"]
        lefts = m["forward_left"] + m["backward_left"]
        rows.append(
            f"| {run} | {m['forward_left']} / {m['forward_right']} / {m['backward_left']} / "
            f"{m['backward_right']} | {lefts} of {steps} (p {m['left_turns_p']:.4f}) | "
            f"{st.median(r['slip_wz_rad_s'] for r in kept):+.3f} | {st.median(left):+.3f} ({len(left)}) | "
            f"{st.median(right):+.3f} ({len(right)}) |"
        )
        steps_rho = [r for r in d["rows"] if not r["excluded"] and r["window"] is None]
        med = st.median(r["rho"] for r in steps_rho)
        counter = [r["rho"] for r in steps_rho if r["cmd_left_rad_s"] * r["cmd_right_rad_s"] < 0]
        rest = [r["rho"] for r in steps_rho if r["cmd_left_rad_s"] * r["cmd_right_rad_s"] >= 0]
        rho_rows.append(
            f"| {run} | {m.get('counter_rotating', len(counter))} of {steps} | {med:.3f} | "
            f"{st.median(counter):.3f} | {sum(1 for x in counter if x >= med)} of {len(counter)} | "
            f"{st.median(rest):.3f} |"
        )
    write_table(
        args.out,
        [
            "run",
            "steps forward-left / forward-right / backward-left / backward-right",
            "left turns (fair-coin p)",
            "median yaw slip (rad/s)",
            "left turns' (windows)",
            "right turns' (windows)",
        ],
        rows,
    )
    header = ["run", "steps with the wheels turning opposite ways", "median ρ", "their median ρ",
              "of them, ρ at or above the run's median", "the other steps' median ρ"]
    table = "| " + " | ".join(header) + " |\n|" + "---|" * len(header) + "\n" + "\n".join(rho_rows) + "\n"
    with open(os.path.join(args.out, "table.md"), "a") as f:
        f.write("\n" + table)
    print(table)


if __name__ == "__main__":
    main()
