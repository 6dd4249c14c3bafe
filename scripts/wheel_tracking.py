#!/usr/bin/env python3
"""How far each wheel follows its command in the steady windows, binned by the kind of command
(both sides one way: "drive"; opposite ways: "turn") and by the larger wheel command (4 rad/s
bins): the median ratio measured / commanded and the largest measured speed per bin.

Reads the `rows` of a `summary.json` written by `drive-sim analyze`, one block per dataset:

    drive-sim analyze ../shared/data/measured/warthog_asphalt.csv --out out/an
    python3 scripts/wheel_tracking.py out/an/summary.json [--ceiling-cmd 13]

Why: a motor that holds its speed whatever the load tracks 1.00 in every bin; one whose torque
falls with its speed gives up speed where the ground resists (the "turn" bins) and reaches a
lower ceiling there (README, "Twins and compare").

A second table per dataset (one value per step, its first steady window): the ceiling against
the load. For steps whose faster wheel is
commanded beyond 13 rad/s (above every measured Warthog ceiling; `--ceiling-cmd 6.5` for the
Husky's 6.1 rad/s), the faster wheel's steady speed binned
by the other wheel's command over the faster one's (below 0.1: pivoting about a nearly stopped
side, the skid-steer's heaviest load; above 0.6: nearly straight). A fixed clamp gives one speed
in every bin; a motor whose torque falls with its speed gives less where the load is heavier
(README, "A ceiling that falls with the load").

A third: how each wheel follows a command below its ceiling (1-10 rad/s), by the same share of
the other wheel's command over its own: measured / commanded, median per bin. An ideal speed loop
gives 1.00 everywhere; one that gives way under load gives less than 1 where the wheel drives
the skid (the faster side, share below 1) and more than 1 where the body drags it (the slower
side of a gentle curve, share above 1) (README, "A speed loop that gives way").
"""
import json
import statistics
import sys


def main():
    args = sys.argv[1:]
    global CEILING_CMD
    if len(args) == 3 and args[1] == "--ceiling-cmd":
        CEILING_CMD = float(args[2])
        args = args[:1]
    if len(args) != 1:
        sys.exit("usage: wheel_tracking.py SUMMARY_JSON [--ceiling-cmd RAD_S]")
    summary = json.load(open(args[0]))
    for d in summary["datasets"]:
        print(f"== {d['dataset']}  (T/U wheels {d['t_area_pct_wheels']:.1f} %)")
        bins = {}
        for r in d["rows"]:
            if (r["window"] or 0) < 1 or r["excluded"] is not None:
                continue
            cl, cr = r["cmd_left_rad_s"], r["cmd_right_rad_s"]
            kind = "turn" if cl * cr < 0 else "drive"
            top = int(max(abs(cl), abs(cr)) // 4) * 4
            for cmd, measured in ((cl, r["left_rad_s"]), (cr, r["right_rad_s"])):
                if abs(cmd) > 1.0:
                    bins.setdefault((kind, top), []).append((measured / cmd, abs(measured)))
        print(f"  {'kind':5} {'|cmd| bin':>10} {'wheels':>7} {'median w/cmd':>13} {'max |w|':>8}")
        for (kind, top), v in sorted(bins.items()):
            print(
                f"  {kind:5} {top:>4}-{top + 4:<5} {len(v):>7} "
                f"{statistics.median(x[0] for x in v):>13.2f} {max(x[1] for x in v):>8.1f}"
            )
        ceiling_by_load(d["rows"])
        tracking_by_share(d["rows"])


# Bins of the other wheel's command over the faster one's, and the faster wheel's command beyond
# which it is at its ceiling on every measured run.
SHARE_BINS = [(-1.0, 0.1, "pivot/turn (< 0.1)"), (0.1, 0.3, "0.1-0.3"), (0.3, 0.6, "0.3-0.6"), (0.6, 1.01, "straight (> 0.6)")]
CEILING_CMD = 13.0


def first_steady_windows(rows):
    """One row per step: its first steady window that the analysis kept."""
    seen = set()
    for r in rows:
        if (r["window"] or 0) < 1 or r["excluded"] is not None or r["step"] in seen:
            continue
        seen.add(r["step"])
        yield r


def bin_of(share, bins):
    """The name of the bin `share` falls in (None outside every bin)."""
    return next((name for lo, hi, name in bins if lo <= share < hi), None)


def ceiling_by_load(rows):
    """The faster wheel's steady speed, one value per step, by the other wheel's share."""
    bins = {b[2]: [] for b in SHARE_BINS}
    for r in first_steady_windows(rows):
        cl, cr = r["cmd_left_rad_s"], r["cmd_right_rad_s"]
        fast_cmd, fast, other = (cl, r["left_rad_s"], cr) if abs(cl) >= abs(cr) else (cr, r["right_rad_s"], cl)
        name = bin_of(other / fast_cmd, SHARE_BINS) if abs(fast_cmd) > CEILING_CMD else None
        if name:
            bins[name].append(abs(fast))
    print(f"  faster wheel commanded beyond {CEILING_CMD:g} rad/s, by the other wheel's share of its command:")
    print(f"  {'share':>17} {'steps':>6} {'median |w|':>11} {'range':>12}")
    for _, _, name in SHARE_BINS:
        v = bins[name]
        if v:
            print(f"  {name:>17} {len(v):>6} {statistics.median(v):>11.1f} {min(v):>5.1f}-{max(v):<5.1f}")
        else:
            print(f"  {name:>17} {0:>6} {'-':>11}")


TRACK_BINS = [(-50.0, 0.1, "pivot/turn (< 0.1)"), (0.1, 0.6, "0.1-0.6"), (0.6, 1.0, "faster side of a curve (0.6-1)"),
              (1.0, 1.7, "slower side of a curve (1-1.7)"), (1.7, 50.0, "slow side (> 1.7)")]


def tracking_by_share(rows):
    """Each wheel commanded 1-10 rad/s: measured / commanded by the other wheel's share."""
    bins = {b[2]: [] for b in TRACK_BINS}
    for r in first_steady_windows(rows):
        cl, cr = r["cmd_left_rad_s"], r["cmd_right_rad_s"]
        for cmd, measured, other in ((cl, r["left_rad_s"], cr), (cr, r["right_rad_s"], cl)):
            name = bin_of(other / cmd, TRACK_BINS) if 1.0 < abs(cmd) < 10.0 else None
            if name:
                bins[name].append(measured / cmd)
    print("  each wheel commanded 1-10 rad/s, measured / commanded by the other wheel's share:")
    print(f"  {'share':>31} {'wheels':>7} {'median':>7}")
    for _, _, name in TRACK_BINS:
        v = bins[name]
        med = f"{statistics.median(v):>7.2f}" if v else f"{'-':>7}"
        print(f"  {name:>31} {len(v):>7} {med}")


if __name__ == "__main__":
    main()
