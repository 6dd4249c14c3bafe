"""drive_sim.run: built-in and Python samplers, the history a sampler sees, what is written,
and the errors of bad samplers and bad names."""

import math
import signal
import threading
import _thread
import time

import pandas as pd
import pytest

import drive_sim

ROBOT, TERRAIN = "husky", "asphalt"


class Recorder:
    """Draws from a fixed small cycle of commands inside U and records what it saw."""

    def __init__(self):
        self.calls = 0
        self.history_lengths = []
        self.drawn = []
        self.last_history = None

    def next_command(self, history):
        self.calls += 1
        self.history_lengths.append(len(history))
        self.last_history = history
        cycle = [(2.0, 3.0), (-1.5, 1.5), (3.0, 2.5), (-2.0, -2.5)]
        cmd = cycle[len(self.drawn) % len(cycle)]
        self.drawn.append(cmd)
        return cmd


def test_builtin_run_in_memory_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = drive_sim.run(ROBOT, TERRAIN, steps=4, seed=1)
    assert r.log is None and r.summary["mcap"] is None
    assert list(tmp_path.iterdir()) == []
    assert isinstance(r.steps, pd.DataFrame)
    assert list(r.steps.columns) == list(drive_sim.STEP_COLUMNS)
    assert list(r.steps["step"]) == [0, 1, 2, 3]
    assert r.summary["summary"]["steps_completed"] == 4
    assert r.summary["sampler"] == "uniform-wheel"
    # The provenance names the Python call, not the interpreter's arguments.
    cmd = r.summary["provenance"]["command"]
    assert len(cmd) == 1 and cmd[0].startswith("drive_sim.run(robot='husky'"), cmd


def test_python_sampler_sees_a_growing_history(tmp_path):
    s = Recorder()
    r = drive_sim.run(ROBOT, TERRAIN, steps=6, seed=2, sampler=s)
    done = r.summary["summary"]
    # Called once per drawn command: once per step, once more per abandoned command.
    assert s.calls == done["steps_completed"] + done["abandoned_commands"]
    assert s.history_lengths[0] == 0
    assert all(b - a in (0, 1) for a, b in zip(s.history_lengths, s.history_lengths[1:]))
    assert s.history_lengths[-1] == 5
    h = s.last_history
    assert list(h.columns) == list(drive_sim.STEP_COLUMNS)
    # The history's commands are the sampler's own, and the run's steps extend the history.
    pd.testing.assert_frame_equal(h, r.steps.iloc[: len(h)])
    drawn = set(s.drawn)
    assert all((row.cmd_left_rad_s, row.cmd_right_rad_s) in drawn for row in r.steps.itertuples())
    # The measured steady state follows the command (encoders near it on asphalt).
    assert (r.steps["enc_left_rad_s"] - r.steps["cmd_left_rad_s"]).abs().max() < 1.0
    assert r.summary["sampler"] == "python:Recorder"


def test_the_logs_commands_are_the_samplers(tmp_path):
    s = Recorder()
    r = drive_sim.run(ROBOT, TERRAIN, steps=5, seed=3, sampler=s, out=tmp_path)
    assert r.log == tmp_path / "husky_asphalt_s3.mcap" and r.log.is_file()
    assert (tmp_path / "husky_asphalt_s3.run.json").is_file()
    a = drive_sim.analyze([r.log])
    logged = [(x.cmd_left_rad_s, x.cmd_right_rad_s) for x in a.steps.itertuples()]
    assert len(logged) > 0
    assert all(c in set(s.drawn) for c in logged)
    # Step by step, the log holds what Run.steps says was drawn.
    by_step = r.steps.set_index("step")
    for x in a.steps.itertuples():
        assert (x.cmd_left_rad_s, x.cmd_right_rad_s) == (
            by_step.loc[x.step, "cmd_left_rad_s"],
            by_step.loc[x.step, "cmd_right_rad_s"],
        )


class Raises:
    def next_command(self, history):
        if len(history) == 2:
            raise RuntimeError("planner exploded")
        return (1.0, 1.0)


class ReturnsNaN:
    def next_command(self, history):
        return (math.nan, 1.0)


class OutsideU:
    def next_command(self, history):
        return (1e3, 1e3)


class WrongArity:
    def next_command(self):
        return (1.0, 1.0)


class NotATuple:
    def next_command(self, history):
        return "forward"


@pytest.mark.parametrize(
    "sampler, step, words",
    [
        (Raises(), 2, "planner exploded"),
        (ReturnsNaN(), 0, "not finite"),
        (OutsideU(), 0, "outside the robot's command space U"),
        (NotATuple(), 0, "must return (left_rad_s, right_rad_s)"),
    ],
)
def test_bad_samplers_stop_the_run_naming_the_step(tmp_path, sampler, step, words):
    with pytest.raises(ValueError) as e:
        drive_sim.run(ROBOT, TERRAIN, steps=4, seed=1, sampler=sampler, out=tmp_path)
    assert f"failed at step {step}" in str(e.value)
    assert words in str(e.value)
    # No log, whole or half-written.
    assert [p.name for p in tmp_path.iterdir() if ".mcap" in p.name] == []


def test_a_samplers_exception_is_the_cause():
    with pytest.raises(ValueError) as e:
        drive_sim.run(ROBOT, TERRAIN, steps=4, seed=1, sampler=Raises())
    assert isinstance(e.value.__cause__, RuntimeError)
    assert str(e.value.__cause__) == "planner exploded"


def test_wrong_arity_is_refused_before_running():
    with pytest.raises(ValueError, match="exactly one argument"):
        drive_sim.run(ROBOT, TERRAIN, steps=4, sampler=WrongArity())
    with pytest.raises(ValueError, match="next_command"):
        drive_sim.run(ROBOT, TERRAIN, steps=4, sampler=object())


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"terrain": "lava"}, "unknown terrain `lava`"),
        ({"robot": "r2d2"}, "unknown robot `r2d2`"),
        ({"sampler": "psychic"}, "unknown sampler `psychic`"),
        ({"steps": 0}, "--steps"),
        ({"steps": -3}, "--steps"),
        ({"noise": "loud"}, "--noise"),
        ({"physics_hz": 1.0}, "--physics-hz"),
        ({"inject": ["no_such_effect=1"]}, "no_such_effect"),
    ],
)
def test_bad_input_raises_value_error_with_the_command_lines_message(tmp_path, kwargs, words):
    args = {"robot": ROBOT, "terrain": TERRAIN, "steps": 3, "out": tmp_path, **kwargs}
    with pytest.raises(ValueError) as e:
        drive_sim.run(**args)
    assert words in str(e.value)
    assert list(tmp_path.iterdir()) == []


def test_ctrl_c_interrupts_a_run(tmp_path):
    # Python's own SIGINT handler, whatever the test runner inherited: a shell starts background
    # jobs with SIGINT ignored, and Python then installs no handler, so `interrupt_main` (like a
    # real Ctrl-C) would do nothing.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.5, _thread.interrupt_main)
    timer.start()
    t0 = time.monotonic()
    try:
        with pytest.raises(KeyboardInterrupt):
            drive_sim.run(ROBOT, TERRAIN, steps=2000, seed=1, out=tmp_path)
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert time.monotonic() - t0 < 30
    # As on the command line, what was simulated is closed as a valid interrupted log.
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".interrupted.mcap")]


def test_catalogs():
    assert {"warthog", "husky"} <= set(drive_sim.robots()["name"])
    assert "asphalt" in set(drive_sim.terrains()["name"])
    s = drive_sim.samplers()
    assert "uniform-wheel" in set(s["name"]) and list(s.columns) == ["name", "summary"]


def test_draw_like_draws_in_the_quadrants_of_a_measured_run():
    import os
    csv = os.path.join(os.path.dirname(__file__), "..", "..", "..", "shared", "data", "measured", "warthog_asphalt.csv")
    real = drive_sim.analyze([csv]).steps.drop_duplicates("step").set_index("step")
    r = drive_sim.run("warthog", "asphalt", steps=12, seed=2, draw_like=csv)
    assert r.summary["sampler"] == "matched-quadrants"
    assert len(r.steps) == 12
    for x in r.steps.itertuples():
        if x.step not in real.index:
            continue
        left, right = real.loc[x.step, "cmd_left_rad_s"], real.loc[x.step, "cmd_right_rad_s"]
        assert (x.cmd_left_rad_s + x.cmd_right_rad_s >= 0) == (left + right >= 0)
        assert (x.cmd_right_rad_s - x.cmd_left_rad_s >= 0) == (right - left >= 0)
    with pytest.raises(ValueError, match="draw_like"):
        drive_sim.run("warthog", "asphalt", steps=3, sampler="halton", draw_like=csv)
