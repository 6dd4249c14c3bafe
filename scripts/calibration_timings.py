#!/usr/bin/env python3
"""Wall and CPU time of `drive-sim calibrate` on the measured datasets, with the per-stage
times of its `timings.json`, whether every fit converged, and the
test score. Run it on an idle machine (it says the load it started with).

    cargo build --release
    python3 scripts/calibration_timings.py [--models kinematic,simulator] [--datasets ...]
        [--discovery] [--out out/timings]

Without `--discovery` the calibrations run with `--no-discovery` (the timing targets are the
calibration's, README "Closing the loop"; discovery is timed by scripts/discovery_table.py).
"""
import argparse
import json
import os
import resource
import subprocess
import sys
import time

DATASETS = ["warthog_asphalt", "warthog_ice", "warthog_gravel", "husky_2023"]


def run(bin_path, data, dataset, model, out, discovery):
    folder = os.path.join(out, f"{dataset}_{model}")
    cmd = [bin_path, "calibrate", os.path.join(data, f"{dataset}.csv"), "--model", model, "--out", folder]
    if not discovery:
        cmd.append("--no-discovery")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.time()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.time() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    with open(os.path.join(folder, "calibration.json")) as f:
        report = json.load(f)
    with open(os.path.join(folder, "timings.json")) as f:
        timings = json.load(f)
    return wall, cpu, report, timings


def effects(report):
    """Each effect's fitted value with its interval (`calibration.json`'s `effects`); an effect
    the robot or terrain file declared is marked with its verdict (`declared_effects`)."""
    verdicts = {}
    for d in report.get("declared_effects", []):
        v = "confirmed" if d["confirmed"] else ("contradicted, off" if d.get("contradicted") else "not confirmed")
        for p in d["params"]:
            verdicts[p["name"]] = v
        if d.get("contradicted"):
            verdicts.setdefault(d["effect"], v)
    out = []
    for e in report["effects"]:
        name = e["name"].removeprefix("effect.")
        ci = e.get("ci95")
        if ci:
            text = f"{name} {e['value']:.3f} [{ci[0]:.3f}, {ci[1]:.3f}]"
        elif e.get("at_bound"):
            text = f"{name} {e['value']:.3f} (at a bound)"
        else:
            text = f"{name} {e['value']:.3f}"
        if e["name"] in verdicts:
            text += f" (declared, {verdicts[e['name']]})"
        out.append(text)
    for d in report.get("declared_effects", []):
        if d.get("contradicted"):
            out.append(f"{d['effect']} (declared, contradicted: switched off)")
    return "; ".join(out) or "none"


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bin", default="target/release/drive-sim")
    p.add_argument("--data", default="../shared/data/measured")
    p.add_argument("--out", default="out/timings")
    p.add_argument("--models", default="kinematic,simulator")
    p.add_argument("--datasets", default=",".join(DATASETS))
    p.add_argument("--discovery", action="store_true")
    a = p.parse_args()
    load = os.getloadavg()[0]
    print(f"load average at start: {load:.2f} on {os.cpu_count()} cores", file=sys.stderr)
    print("| dataset | model | wall s | CPU s | stages (s) | fits converged | test score IDD / declared → "
          "calibrated (reduction ± bootstrap SE) | effects (95 % interval) |")
    print("|---|---|---|---|---|---|---|---|")
    for model in a.models.split(","):
        for dataset in a.datasets.split(","):
            wall, cpu, r, t = run(a.bin, a.data, dataset, model, a.out, a.discovery)
            stages = ", ".join(f"{s['stage']} {s['wall_s']:.1f}" for s in t["stages"] if s["wall_s"] >= 0.05)
            conv = r.get("status", {}).get("converged")
            print(
                f"| {dataset} | {model} | {wall:.1f} | {cpu:.1f} | {stages} | {conv} "
                f"| {r['idd']['score']:.1f} / {r['before']['score']:.1f} → {r['after']['score']:.2f} "
                f"(−{r['total_reduction']:.1f} ± {r['total_reduction_se']:.1f}) | {effects(r)} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
