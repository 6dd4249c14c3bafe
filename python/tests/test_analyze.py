"""drive_sim.analyze gives the command line's figures; compare and calibrate reach the library."""

import json
import math

import pytest

import drive_sim

from conftest import run_cli


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    out = tmp_path_factory.mktemp("logs")
    return drive_sim.run("warthog", "gravel", steps=12, seed=4, out=out).log


def _same(a, b, path="$"):
    """Equal JSON values, NaN (null) included; provenance (the command differs) left out."""
    if isinstance(a, dict):
        assert set(a) == set(b), path
        for k in a:
            if k != "provenance":
                _same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{path}[{i}]")
    elif isinstance(a, float) and isinstance(b, float) and math.isnan(a):
        assert math.isnan(b), path
    else:
        assert a == b, f"{path}: {a!r} != {b!r}"


def test_analyze_gives_the_command_lines_figures(cli, log, tmp_path):
    run_cli(cli, "analyze", str(log), "--out", str(tmp_path / "cli"))
    with open(tmp_path / "cli" / "summary.json", encoding="utf-8") as f:
        expected = json.load(f)
    a = drive_sim.analyze(log, out=tmp_path / "py")
    _same(expected, a.summary)
    assert a.report == tmp_path / "py" / "report.html" and a.report.is_file()
    d = expected["datasets"][0]
    # One steady row per analysed step, with the rho the statistics use.
    steady = [r for r in d["rows"] if r["window"] is None and r["excluded"] is None]
    assert len(a.steps) == d["steps_analysed"] == len(steady)
    assert list(a.steps["rho"]) == [r["rho"] for r in steady]
    assert list(a.steps["cmd_left_rad_s"]) == [r["cmd_left_rad_s"] for r in steady]
    for c in ("dataset", "step", "rho", "slip_vx_m_s", "slip_left_rad_s", "cmd_right_rad_s"):
        assert c in a.steps.columns
    med = sorted(a.steps["rho"])[len(a.steps) // 2] if len(a.steps) % 2 else None
    if med is not None:
        assert med == pytest.approx(d["stats"]["rho"]["median"])


def test_analyze_without_out_writes_nothing(log, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    a = drive_sim.analyze([str(log)])
    assert a.report is None and len(a.steps) > 0
    assert list(tmp_path.iterdir()) == []


def test_analyze_errors(tmp_path):
    with pytest.raises(OSError):
        drive_sim.analyze(tmp_path / "missing.mcap")
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"not an mcap")
    with pytest.raises(ValueError):
        drive_sim.analyze(bad)
    with pytest.raises(ValueError, match="--resolution"):
        drive_sim.analyze(bad, resolution=0.0)


def test_compare_reaches_the_library(log, tmp_path):
    sim = drive_sim.run("warthog", "gravel", steps=12, seed=5, out=tmp_path).log
    c = drive_sim.compare(log, [sim], resamples=200, permutations=0)
    assert isinstance(c.summary, dict) and c.summary
    with pytest.raises(ValueError, match="--tf-smoother"):
        drive_sim.compare(log, [sim], tf_smoother="spline")


def test_calibrate_reaches_the_library(tmp_path):
    log = drive_sim.run("warthog", "gravel", steps=20, seed=4, out=tmp_path / "logs").log
    c = drive_sim.calibrate(log, tmp_path / "cal", model="kinematic", max_effects=1, discover=False)
    assert (tmp_path / "cal" / "calibration.json") in c.files
    assert c.summary["dataset"] == "warthog_gravel_s4"
    with pytest.raises(ValueError, match="unknown model `nonsense`"):
        drive_sim.calibrate(log, model="nonsense")


def test_twin_reaches_the_library(log, tmp_path):
    # Bad options are refused before any long work, with the command line's message.
    with pytest.raises(ValueError, match="--budget"):
        drive_sim.twin(log, tmp_path / "twin", budget=100.0)
    assert not (tmp_path / "twin").exists()
    with pytest.raises(OSError):
        drive_sim.twin(tmp_path / "missing.mcap")
