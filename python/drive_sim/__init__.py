"""drive_sim: the DRIVE protocol's simulation-backed test harness, from Python.

The same library as the ``drive-sim`` command line, called directly: a DRIVE run on the
simulated robot (:func:`run`), with a built-in sampler or one written in Python; the slip and
unpredictability (rho) analysis of logs (:func:`analyze`); the comparison of a real log with
simulated ones (:func:`compare`); the calibration of a model (:func:`calibrate`); a judged
twin made from runs (:func:`twin`); and
what a run can name (:func:`robots`, :func:`terrains`, :func:`samplers`).

Results are dicts (the JSON the command line writes) and pandas DataFrames. Bad input raises
``ValueError`` with the command line's message, I/O failures ``OSError``, and Ctrl-C stops a
run with ``KeyboardInterrupt``.

Example::

    import drive_sim

    r = drive_sim.run("warthog", "gravel", steps=30, seed=1)
    print(r.summary["summary"]["time_efficiency"], len(r.steps))
"""

from __future__ import annotations

import inspect
import json
import os
import tempfile
from pathlib import Path
from typing import Any, Iterable, Optional, Sequence, Tuple, Union

import numpy as np
import pandas as pd

from . import _native

__all__ = [
    "Analysis",
    "Calibration",
    "Comparison",
    "Run",
    "STEP_COLUMNS",
    "analyze",
    "calibrate",
    "compare",
    "robots",
    "run",
    "samplers",
    "terrains",
    "Twin",
    "twin",
]

__version__: str = _native.__version__

#: The columns of :attr:`Run.steps` and of a Python sampler's ``history``, in order: the step,
#: the attempts it took, the log time of its last sample (s), the command (rad/s), and the means
#: over its steady windows of the encoders (rad/s), the IMU yaw rate (rad/s) and the body
#: velocity from the pose (vx, vy in m/s, wz in rad/s).
STEP_COLUMNS: Tuple[str, ...] = tuple(_native.STEP_COLUMNS)

_INT_COLUMNS = ("step", "attempts")
assert STEP_COLUMNS[: len(_INT_COLUMNS)] == _INT_COLUMNS

PathLike = Union[str, "os.PathLike[str]"]


class Run:
    """A DRIVE run made by :func:`run`.

    Attributes:
        log: The MCAP log's path, or ``None`` when the run was kept in memory (``out=None``).
        steps: One row per completed step (:data:`STEP_COLUMNS`): the command as drawn and
            the measured steady state.
        summary: The run's report, as the command line's ``<name>.run.json`` (``mcap`` is
            ``None``, ``mcap_bytes`` 0, when nothing was written).
    """

    __slots__ = ("log", "steps", "summary")

    def __init__(self, log: Optional[Path], steps: pd.DataFrame, summary: dict) -> None:
        self.log = log
        self.steps = steps
        self.summary = summary

    def __repr__(self) -> str:
        s = self.summary.get("summary", {})
        return (
            f"Run(steps={s.get('steps_completed')}, interruptions={s.get('interruptions')}, "
            f"log={str(self.log) if self.log else None!r})"
        )


class Analysis:
    """The analysis of logs made by :func:`analyze`.

    Attributes:
        summary: ``summary.json`` of ``drive-sim analyze``: per dataset the aggregates (medians,
            intervals, the rows per step and window).
        steps: One steady-state row per analysed step of every log (the rows whose rho the
            statistics use; no per-window rows), with a ``dataset`` column.
        report: The HTML report's path, or ``None`` when no ``out`` was given.
    """

    __slots__ = ("summary", "steps", "report")

    def __init__(self, summary: dict, steps: pd.DataFrame, report: Optional[Path]) -> None:
        self.summary = summary
        self.steps = steps
        self.report = report

    def __repr__(self) -> str:
        names = [d.get("dataset") for d in self.summary.get("datasets", [])]
        return f"Analysis(datasets={names!r}, steps={len(self.steps)})"


class Comparison:
    """A comparison made by :func:`compare`.

    Attributes:
        summary: ``comparison.json`` of ``drive-sim compare``.
        files: The files written (empty when no ``out`` was given).
    """

    __slots__ = ("summary", "files")

    def __init__(self, summary: dict, files: Sequence[Path]) -> None:
        self.summary = summary
        self.files = list(files)

    def __repr__(self) -> str:
        return f"Comparison(files={len(self.files)})"


class Calibration:
    """A calibration made by :func:`calibrate`.

    Attributes:
        summary: ``calibration.json`` of ``drive-sim calibrate``.
        files: The files written (empty when no ``out`` was given).
    """

    __slots__ = ("summary", "files")

    def __init__(self, summary: dict, files: Sequence[Path]) -> None:
        self.summary = summary
        self.files = list(files)

    def __repr__(self) -> str:
        return f"Calibration(files={len(self.files)})"


class Twin:
    """A twin made by :func:`twin`.

    Attributes:
        summary: ``twin.json`` of ``drive-sim twin``.
        files: The files written (empty when no ``out`` was given).
    """

    __slots__ = ("summary", "files")

    def __init__(self, summary: dict, files: Sequence[Path]) -> None:
        self.summary = summary
        self.files = list(files)

    def __repr__(self) -> str:
        return f"Twin(files={len(self.files)})"


class _History:
    """The completed steps, appended as they come into preallocated buffers that a DataFrame
    shares (no copy; one block of integer columns, one of floats, so that slicing is cheap);
    :meth:`frame` is that DataFrame's first rows, a view: nothing is rebuilt per draw. Rows once
    written never change, so a view handed out stays true; a sampler that writes into its
    history gets its own copy (pandas' copy-on-write)."""

    _NI = len(_INT_COLUMNS)
    _VIEW_BATCH = 32

    def __init__(self, capacity: int) -> None:
        self._n = 0
        self._ints = np.zeros((0, self._NI), dtype=np.int64)
        self._floats = np.zeros((0, len(STEP_COLUMNS) - self._NI))
        self._full = pd.DataFrame()
        self._alloc(max(int(capacity), 1))

    def _alloc(self, capacity: int) -> None:
        n = self._n
        ints = np.zeros((capacity, self._NI), dtype=np.int64)
        floats = np.zeros((capacity, len(STEP_COLUMNS) - self._NI))
        ints[:n], floats[:n] = self._ints[:n], self._floats[:n]
        self._ints, self._floats = ints, floats
        # Flat views for writing a row value by value: no numpy call per row (one costs tens
        # of microseconds when it runs between two simulated steps, its code cold by then).
        self._int_cells = memoryview(ints).cast("B").cast("q")
        self._float_cells = memoryview(floats).cast("B").cast("d")
        self._views: list = []
        self._views_from = 0
        self._full = pd.concat(
            [
                pd.DataFrame(ints, columns=list(STEP_COLUMNS[: self._NI]), copy=False),
                pd.DataFrame(floats, columns=list(STEP_COLUMNS[self._NI :]), copy=False),
            ],
            axis=1,
        )

    def append(self, rows: Sequence[tuple]) -> None:
        if not rows:
            return
        end = self._n + len(rows)
        if end > len(self._ints):
            self._alloc(max(end, 2 * len(self._ints)))
        ni, nf = self._NI, len(STEP_COLUMNS) - self._NI
        ic, fc = self._int_cells, self._float_cells
        for i, r in enumerate(rows, start=self._n):
            for j in range(ni):
                ic[i * ni + j] = r[j]
            for j in range(nf):
                fc[i * nf + j] = r[ni + j]
        self._n = end

    def __len__(self) -> int:
        return self._n

    def frame(self) -> pd.DataFrame:
        n = self._n
        if n == len(self._full):
            return self._full
        k = n - self._views_from
        if not 0 <= k < len(self._views):
            # The views of the next rows, made together: a slice made alone between two
            # simulated steps costs several times more (pandas' code is cold by then).
            stop = min(n + self._VIEW_BATCH, len(self._full))
            self._views = [self._full.iloc[:m] for m in range(n, stop)]
            self._views_from, k = n, 0
        return self._views[k]


class _Adapter:
    """What the Rust loop calls for each draw: hands the newly completed steps to the history
    and asks the user's sampler for the next command."""

    def __init__(self, sampler: Any, capacity: int) -> None:
        self.sampler = sampler
        self.history = _History(capacity)
        self.calls = 0

    def __call__(self, step: int, rows: Sequence[tuple]) -> Tuple[float, float]:
        self.history.append(rows)
        self.calls += 1
        cmd = self.sampler.next_command(self.history.frame())
        try:
            left, right = cmd
            return float(left), float(right)
        except (TypeError, ValueError) as e:
            raise ValueError(
                f"next_command must return (left_rad_s, right_rad_s), got {cmd!r}"
            ) from e


def _check_sampler(sampler: Any) -> Any:
    """The sampler's ``next_command``, checked to take exactly one argument."""
    method = getattr(sampler, "next_command", None)
    if not callable(method):
        raise ValueError(
            "sampler must be a built-in sampler's name (drive_sim.samplers()) or an object "
            f"with a method next_command(self, history); got {sampler!r}"
        )
    try:
        sig = inspect.signature(method)
    except (TypeError, ValueError):
        return method  # a builtin or C callable: its arity shows when called
    try:
        sig.bind(None)
    except TypeError:
        raise ValueError(
            f"{type(sampler).__name__}.next_command{sig} must take exactly one argument "
            "(history, a DataFrame of the completed steps)"
        ) from None
    return method


def _call(_function: str, **kwargs: Any) -> list:
    """The provenance's command: the Python call, as written."""
    args = ", ".join(f"{k}={v!r}" for k, v in kwargs.items())
    return [f"drive_sim.{_function}({args})"]


def _path(p: Optional[PathLike]) -> Optional[str]:
    return None if p is None else os.fspath(p)


def _paths(ps: Union[PathLike, Iterable[PathLike]]) -> list:
    if isinstance(ps, (str, os.PathLike)):
        return [os.fspath(ps)]
    return [os.fspath(p) for p in ps]


def _steps_frame(rows: Sequence[tuple]) -> pd.DataFrame:
    h = _History(len(rows))
    h.append(rows)
    return h.frame()


def run(
    robot: str,
    terrain: str,
    steps: int,
    seed: int = 0,
    sampler: Any = "uniform-wheel",
    out: Optional[PathLike] = None,
    *,
    noise: str = "typical",
    physics_hz: float = 100.0,
    safe_area: Optional[Tuple[float, float]] = None,
    inject: Sequence[str] = (),
    name: Optional[str] = None,
    force: bool = False,
    draw_like: Optional[PathLike] = None,
) -> Run:
    """Runs DRIVE on the simulated robot, as ``drive-sim run`` does.

    Args:
        robot: Robot name (:func:`robots`) or path to a robot TOML file.
        terrain: Terrain name (:func:`terrains`) or path to a terrain TOML file.
        steps: Steps to complete (the paper: at least 150).
        seed: Seed of every random draw (commands, terrain roughness, sensor noise).
        sampler: A built-in sampler's name (:func:`samplers`), or any object with a method
            ``next_command(self, history)`` returning ``(left_rad_s, right_rad_s)``. It is
            called whenever the protocol draws a command (once per step, and again for a step
            whose command the safety operator abandoned), with ``history``, a DataFrame of
            the steps completed so far (:data:`STEP_COLUMNS`). An exception, a NaN or a
            command outside the robot's command space U stops the run with a ``ValueError``
            naming the step (the exception as its cause); no log is left.
        out: Directory to write ``<name>.mcap`` and ``<name>.run.json`` into; ``None`` keeps
            the run in memory and writes nothing.
        noise: Sensor noise, ``"typical"`` or ``"off"``.
        physics_hz: Physics rate, Hz.
        safe_area: The deployment's safe area ``(length_m, width_m)`` instead of the robot
            file's.
        inject: Effects the log's metadata does not declare, ``"NAME=VALUE"`` each.
        name: Log name (file stem); default ``<robot>_<terrain>_s<seed>``.
        force: Overwrite a log of the same name made with other options.
        draw_like: A log (any ``drive-sim`` input) whose commands' quadrants the run draws in,
            step by step, instead of ``sampler`` (``drive-sim run --draw-like``): a run to
            compare with that log, as ``tune``, ``twin`` and ``judge`` draw a twin's runs.

    Returns:
        The :class:`Run`.
    """
    if draw_like is not None and sampler != "uniform-wheel":
        raise ValueError("<command line>: `draw_like` and `sampler` both say how commands are drawn: give one")
    if isinstance(sampler, str):
        adapter, label = None, sampler
    else:
        _check_sampler(sampler)
        adapter = _Adapter(sampler, steps if isinstance(steps, int) and 0 < steps <= 100_000 else 1)
        label = f"python:{type(sampler).__name__}"
    command = _call(
        "run", robot=robot, terrain=terrain, steps=steps, seed=seed, sampler=label,
        out=_path(out), noise=noise, physics_hz=physics_hz, safe_area=safe_area,
        inject=list(inject), name=name, force=force,
        **({} if draw_like is None else {"draw_like": _path(draw_like)}),
    )
    report, log, rows = _native.run(
        robot, terrain, steps, seed, label, adapter, _path(out), name, force, noise,
        float(physics_hz), None if safe_area is None else tuple(map(float, safe_area)),
        list(inject), command, _path(draw_like),
    )
    summary = json.loads(report)
    if not log:
        # Nothing written: no log to name (the command line's run.json always has one).
        summary["mcap"] = None
    return Run(Path(log) if log else None, _steps_frame(rows), summary)


def _analysis_steps(per_log: Sequence[Tuple[str, str]]) -> pd.DataFrame:
    frames = []
    for dataset, rows in per_log:
        df = pd.DataFrame(json.loads(rows))
        df.insert(0, "dataset", dataset)
        frames.append(df)
    steps = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
    return steps.drop(columns=[c for c in ("window", "excluded") if c in steps.columns])


def analyze(
    paths: Union[PathLike, Iterable[PathLike]],
    out: Optional[PathLike] = None,
    *,
    resolution: float = 0.1,
    kernel_variance: Optional[float] = None,
    keep_pose_contradictions: bool = False,
    robot: Optional[str] = None,
    terrain: Optional[str] = None,
    roles: Optional[str] = None,
) -> Analysis:
    """Analyses DRIVE logs, as ``drive-sim analyze`` does (the same numbers).

    Args:
        paths: Logs: ``.mcap`` written by :func:`run` or ``drive-sim run``, measured ``.csv``
            (JSON beside it), or rosbag2 bags.
        out: Directory for the report (``summary.json``, ``report.html``, figures);
            ``None`` writes it to a temporary directory removed afterwards.
        resolution: Transfer-function grid resolution in vx (m/s) and wz (rad/s).
        kernel_variance: Kernel variance; default the paper's value for the log's robot.
        keep_pose_contradictions: Keep steps whose pose contradicts the encoders.
        robot, terrain, roles: How to read a bag (``--robot``, ``--terrain``, ``--roles``).

    Returns:
        The :class:`Analysis`.
    """
    logs = _paths(paths)
    command = _call(
        "analyze", paths=logs, out=_path(out), resolution=resolution,
        kernel_variance=kernel_variance, keep_pose_contradictions=keep_pose_contradictions,
        robot=robot, terrain=terrain, roles=roles,
    )

    def go(dest: str) -> Analysis:
        per_log = _native.analyze(
            logs, dest, float(resolution), kernel_variance, keep_pose_contradictions,
            robot, terrain, roles, command,
        )
        with open(os.path.join(dest, "summary.json"), encoding="utf-8") as f:
            summary = json.load(f)
        report = Path(dest) / "report.html" if out is not None else None
        return Analysis(summary, _analysis_steps(per_log), report)

    if out is not None:
        return go(os.fspath(out))
    with tempfile.TemporaryDirectory(prefix="drive_sim_analysis_") as tmp:
        return go(os.path.join(tmp, "analysis"))


def compare(
    real: PathLike,
    sims: Union[PathLike, Iterable[PathLike]],
    out: Optional[PathLike] = None,
    *,
    resamples: Optional[int] = None,
    seed: Optional[int] = None,
    alpha: float = 0.05,
    permutations: Optional[int] = None,
    tf_smoother: str = "kernel",
    yardstick_splits: Optional[int] = None,
    real_steps: str = "all",
    robot: Optional[str] = None,
    terrain: Optional[str] = None,
    roles: Optional[str] = None,
) -> Comparison:
    """Compares a real log with simulated ones, as ``drive-sim compare`` does.

    Options left ``None`` take the command line's defaults. ``out=None`` writes the report to
    a temporary directory removed afterwards.

    Returns:
        The :class:`Comparison` (``summary`` is ``comparison.json``).
    """
    sim_paths = _paths(sims)
    command = _call(
        "compare", real=os.fspath(real), sims=sim_paths, out=_path(out), resamples=resamples,
        seed=seed, alpha=alpha, permutations=permutations, tf_smoother=tf_smoother,
        yardstick_splits=yardstick_splits, real_steps=real_steps, robot=robot,
        terrain=terrain, roles=roles,
    )

    def go(dest: str) -> Comparison:
        text = _native.compare(
            os.fspath(real), sim_paths, dest, resamples, seed, float(alpha), permutations,
            tf_smoother, yardstick_splits, real_steps, robot, terrain, roles, command,
        )
        files = sorted(p for p in Path(dest).rglob("*") if p.is_file()) if out is not None else []
        return Comparison(json.loads(text), files)

    if out is not None:
        return go(os.fspath(out))
    with tempfile.TemporaryDirectory(prefix="drive_sim_compare_") as tmp:
        return go(os.path.join(tmp, "compare"))


def calibrate(
    logs: Union[PathLike, Iterable[PathLike]],
    out: Optional[PathLike] = None,
    *,
    model: str = "simulator",
    optimizer: str = "levenberg-marquardt",
    seed: int = 0,
    max_effects: Optional[int] = None,
    max_fit_steps: Optional[int] = None,
    candidates: Optional[Sequence[str]] = None,
    use_steps: str = "all",
    discover: bool = True,
    robot: Optional[str] = None,
    terrain: Optional[str] = None,
    roles: Optional[str] = None,
) -> Calibration:
    """Calibrates a model on logs, as ``drive-sim calibrate`` does (one log alone, several
    jointly). ``out=None`` writes to a temporary directory removed afterwards.

    Returns:
        The :class:`Calibration` (``summary`` is ``calibration.json``).
    """
    log_paths = _paths(logs)
    command = _call(
        "calibrate", logs=log_paths, out=_path(out), model=model, optimizer=optimizer,
        seed=seed, max_effects=max_effects, max_fit_steps=max_fit_steps,
        candidates=None if candidates is None else list(candidates), use_steps=use_steps,
        discover=discover, robot=robot, terrain=terrain, roles=roles,
    )

    def go(dest: str) -> Calibration:
        _native.calibrate(
            log_paths, dest, model, optimizer, seed, max_effects, max_fit_steps,
            None if candidates is None else list(candidates), use_steps, discover, robot,
            terrain, roles, command,
        )
        with open(os.path.join(dest, "calibration.json"), encoding="utf-8") as f:
            summary = json.load(f)
        files = sorted(p for p in Path(dest).rglob("*") if p.is_file()) if out is not None else []
        return Calibration(summary, files)

    if out is not None:
        return go(os.fspath(out))
    with tempfile.TemporaryDirectory(prefix="drive_sim_calibration_") as tmp:
        return go(os.path.join(tmp, "calibration"))


def twin(
    logs: Union[PathLike, Iterable[PathLike]],
    out: Optional[PathLike] = None,
    *,
    seed: int = 0,
    budget: float = 1.0,
    leave_one_out: bool = True,
    judge_sims: Optional[int] = None,
    judge_references: Optional[int] = None,
    knobs: Optional[Sequence[str]] = None,
    robot: Optional[str] = None,
    terrain: Optional[str] = None,
    roles: Optional[str] = None,
) -> Twin:
    """Makes a judged twin of a robot from its DRIVE runs, as ``drive-sim twin`` does
    (calibrate, choose what to tune, tune, check, judge). Options left ``None`` take the
    command line's defaults; ``out=None`` writes to a temporary directory removed afterwards.

    Returns:
        The :class:`Twin` (``summary`` is ``twin.json``).
    """
    log_paths = _paths(logs)
    command = _call(
        "twin", logs=log_paths, out=_path(out), seed=seed, budget=budget,
        leave_one_out=leave_one_out, judge_sims=judge_sims, judge_references=judge_references,
        knobs=None if knobs is None else list(knobs), robot=robot, terrain=terrain, roles=roles,
    )

    def go(dest: str) -> Twin:
        text = _native.twin(
            log_paths, dest, seed, float(budget), leave_one_out, judge_sims, judge_references,
            None if knobs is None else list(knobs), robot, terrain, roles, command,
        )
        files = sorted(p for p in Path(dest).rglob("*") if p.is_file()) if out is not None else []
        return Twin(json.loads(text), files)

    if out is not None:
        return go(os.fspath(out))
    with tempfile.TemporaryDirectory(prefix="drive_sim_twin_") as tmp:
        return go(os.path.join(tmp, "twin"))


def _catalog(entries: Sequence[str]) -> pd.DataFrame:
    df = pd.json_normalize([json.loads(e) for e in entries])
    df = df.drop(columns=[c for c in ("parameters.name",) if c in df.columns])
    prefix = "parameters."
    return df.rename(columns=lambda c: c[len(prefix) :] if c.startswith(prefix) else c)


def robots() -> pd.DataFrame:
    """The robots a run can name (built-in, ``./robots/``, ``$DRIVE_SIM_DATA/robots/``): one
    row each, ``name``, ``source`` and the file's parameters (flattened: ``body.mass_kg``)."""
    return _catalog(_native.robots())


def terrains() -> pd.DataFrame:
    """The terrains a run can name, as :func:`robots` lists robots."""
    return _catalog(_native.terrains())


def samplers() -> pd.DataFrame:
    """The built-in samplers: ``name`` and ``summary``, in the command line's order."""
    return pd.DataFrame(_native.samplers(), columns=["name", "summary"])
