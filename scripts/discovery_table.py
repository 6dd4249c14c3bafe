#!/usr/bin/env python3
"""The discovery table on the measured data: per channel, the residual / noise floor on the test steps before
(declared model) and after calibration with discovery, for every measured dataset and both
models. Runs `drive-sim calibrate` once per dataset and model (skipping those whose
calibration.json is already in OUT), then prints a Markdown table.

    cargo build --release
    python3 scripts/discovery_table.py --out out/discovery_table [--models kinematic,simulator]
"""
import argparse
import json
import os
import subprocess
import sys
import time

DATASETS = ["warthog_asphalt", "warthog_asphalt_b", "warthog_ice", "warthog_gravel", "husky_2023"]


def calibrate(bin_path, data, dataset, model, out):
    folder = os.path.join(out, f"{dataset}_{model}")
    report = os.path.join(folder, "calibration.json")
    if not os.path.exists(report):
        log = os.path.join(data, f"{dataset}.csv")
        t0 = time.time()
        print(f"calibrate {dataset} ({model}) ...", file=sys.stderr, flush=True)
        subprocess.run(
            [bin_path, "calibrate", log, "--model", model, "--out", folder],
            check=True,
            stdout=subprocess.DEVNULL,
        )
        print(f"  {time.time() - t0:.0f} s", file=sys.stderr, flush=True)
    with open(report) as f:
        return json.load(f)


def ratios(diagnosis):
    return {c["channel"]: c for c in (diagnosis or {}).get("channels", [])}


def added(report):
    rounds = (report.get("discovery") or {}).get("rounds", [])
    return [r["added"] for r in rounds if r.get("added")]


def competition(report):
    c = (report.get("discovery") or {}).get("competition")
    if not c:
        return "not run"
    first = c["discovery_first"]
    return (f"{c['kept']} kept (from the base model: {', '.join(first['effects']) or 'nothing'}, "
            f"{first['parameters']} parameters, validation {first['validation_score']:.2f} against "
            f"{c['catalogue_first']['validation_score']:.2f} ± {c['se']:.2f})")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bin", default="target/release/drive-sim")
    p.add_argument("--data", default="../shared/data/measured")
    p.add_argument("--out", default="out/discovery_table")
    p.add_argument("--models", default="kinematic,simulator")
    p.add_argument("--datasets", default=",".join(DATASETS))
    a = p.parse_args()
    runs = []
    for model in a.models.split(","):
        for dataset in a.datasets.split(","):
            runs.append((dataset, model, calibrate(a.bin, a.data, dataset, model, a.out)))
    channels = []
    for _, _, r in runs:
        for c in ratios(r.get("diagnosis_before")):
            if c not in channels:
                channels.append(c)
    head = "| channel (flag) | " + " | ".join(f"{d} {m}" for d, m, _ in runs) + " |"
    print(head)
    print("|---" * (len(runs) + 1) + "|")
    for ch in channels:
        cells = []
        threshold = None
        for _, _, r in runs:
            b, f = ratios(r.get("diagnosis_before")).get(ch), ratios(r.get("diagnosis_after")).get(ch)
            if b is None or f is None:
                cells.append("—")
                continue
            threshold = f["threshold"]
            mark = "**" if f["flagged"] else ""
            cells.append(f"{b['ratio']:.2f} → {mark}{f['ratio']:.2f}{mark}")
        print(f"| {ch} ({threshold:g}) | " + " | ".join(cells) + " |")
    print("| test score | " + " | ".join(
        f"{r['before']['score']:.3g} → {r['after']['score']:.3g}" if isinstance(r.get("before"), dict) else "—"
        for _, _, r in runs) + " |")
    print("| added by discovery | " + " | ".join(", ".join(added(r)) or "—" for _, _, r in runs) + " |")
    print("| competition | " + " | ".join(competition(r) for _, _, r in runs) + " |")
    print("| effects | " + " | ".join(
        ", ".join(e["name"].removeprefix("effect.") for e in r.get("effects", [])) or "—"
        for _, _, r in runs) + " |")


if __name__ == "__main__":
    main()
