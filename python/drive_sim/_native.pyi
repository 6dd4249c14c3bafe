"""Type stubs of the extension module ``drive_sim._native`` (crates/drive-sim-py). Use the
functions of :mod:`drive_sim`, which wrap these with defaults, DataFrames and dicts."""

from os import PathLike
from typing import Callable, List, Optional, Sequence, Tuple, Union

_Path = Union[str, "PathLike[str]"]
_Row = Tuple[int, int, float, float, float, float, float, float, float, float, float]

__version__: str
STEP_COLUMNS: List[str]

def run(
    robot: str,
    terrain: str,
    steps: int,
    seed: int,
    sampler: str,
    adapter: Optional[Callable[[int, List[_Row]], Tuple[float, float]]],
    out: Optional[_Path],
    name: Optional[str],
    force: bool,
    noise: str,
    physics_hz: float,
    safe_area: Optional[Tuple[float, float]],
    inject: Sequence[str],
    command: Sequence[str],
    draw_like: Optional[_Path] = None,
) -> Tuple[str, Optional[str], List[_Row]]:
    """Runs DRIVE; returns the run.json text, the log's path (None in memory) and the rows."""

def analyze(
    logs: Sequence[_Path],
    out: _Path,
    resolution: float,
    kernel_variance: Optional[float],
    keep_pose_contradictions: bool,
    robot: Optional[str],
    terrain: Optional[str],
    roles: Optional[str],
    command: Sequence[str],
) -> List[Tuple[str, str]]:
    """Analyses logs into out; returns (dataset, steady rows as JSON) per log."""

def compare(
    real: _Path,
    sims: Sequence[_Path],
    out: _Path,
    resamples: Optional[int],
    seed: Optional[int],
    alpha: float,
    permutations: Optional[int],
    tf_smoother: str,
    yardstick_splits: Optional[int],
    real_steps: str,
    robot: Optional[str],
    terrain: Optional[str],
    roles: Optional[str],
    command: Sequence[str],
) -> str:
    """Compares into out; returns comparison.json's text."""

def calibrate(
    logs: Sequence[_Path],
    out: _Path,
    model: str,
    optimizer: str,
    seed: int,
    max_effects: Optional[int],
    max_fit_steps: Optional[int],
    candidates: Optional[Sequence[str]],
    use_steps: str,
    discover: bool,
    robot: Optional[str],
    terrain: Optional[str],
    roles: Optional[str],
    command: Sequence[str],
) -> List[str]:
    """Calibrates into out; returns the files written."""

def twin(
    logs: Sequence[_Path],
    out: _Path,
    seed: int,
    budget: float,
    leave_one_out: bool,
    judge_sims: Optional[int],
    judge_references: Optional[int],
    knobs: Optional[Sequence[str]],
    robot: Optional[str],
    terrain: Optional[str],
    roles: Optional[str],
    command: Sequence[str],
) -> str:
    """Makes a twin into out; returns twin.json's text."""

def robots() -> List[str]:
    """Each robot as JSON: name, source, parameters (or error)."""

def terrains() -> List[str]:
    """Each terrain as JSON: name, source, parameters (or error)."""

def samplers() -> List[Tuple[str, str]]:
    """The built-in samplers: (name, summary)."""

