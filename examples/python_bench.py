"""The Python package's overheads, measured (numbers in docs/results/python.md).

1. A Python sampler against the built-in one, side by side in one process: a 150-step run
   with the built-in `uniform-wheel`, then the same run with a Python sampler that replays the
   built-in run's commands in order (so both simulate exactly the same steps; checked), each
   repeated and alternated; the median wall times and the Python sampler's share.
2. `Run.steps` of a 150-step run: the time to build the DataFrame from the run's rows.
3. A sampler's history: the time per draw to append a row and hand the DataFrame over.
4. With --instructions: the instructions (callgrind) of a built-in run and of the Python
   sampler's replay, which the machine's other load does not change.

Run from the repository root after `pip install .` (or `maturin develop`):

    python examples/python_bench.py [--robot warthog] [--terrain asphalt] [--steps 150] [--repeat 3] [--instructions]
"""

import argparse
import platform
import re
import statistics
import subprocess
import sys
import time

import drive_sim


class Replay:
    """Returns the given commands in order; reads the history as a real sampler would."""

    def __init__(self, commands):
        self.commands = list(commands)
        self.i = 0
        self.seen = 0

    def next_command(self, history):
        self.seen += len(history)
        c = self.commands[self.i]
        self.i += 1
        return c


def timed_run(robot, terrain, steps, seed, sampler):
    """The run, its wall time and the process's CPU time over it, s."""
    t0, c0 = time.perf_counter(), time.process_time()
    r = drive_sim.run(robot, terrain, steps, seed=seed, sampler=sampler)
    return (time.perf_counter() - t0, time.process_time() - c0), r


def replayable(robot, terrain, steps, seed):
    """The first seed from `seed` on whose built-in run abandoned no command (an abandoned
    command is not in Run.steps, so a replay of the steps would draw other commands from there
    on), and that run."""
    for s in range(seed, seed + 20):
        _, ref = timed_run(robot, terrain, steps, s, "uniform-wheel")
        if ref.summary["summary"]["abandoned_commands"] == 0:
            return s, ref
        print(f"seed {s}: abandoned commands, not replayable; next seed")
    raise SystemExit("no replayable seed in 20")


def one(a) -> None:
    """The process callgrind counts: the reference run, then (unless `setup`) one more run."""
    seed, ref = replayable(a.robot, a.terrain, a.steps, a.seed)
    replay = list(zip(ref.steps["cmd_left_rad_s"], ref.steps["cmd_right_rad_s"]))
    if a.one == "builtin":
        timed_run(a.robot, a.terrain, a.steps, seed, "uniform-wheel")
    elif a.one == "python":
        timed_run(a.robot, a.terrain, a.steps, seed, Replay(replay))


def instructions(a) -> None:
    """Instructions (callgrind) of the same process with no further run, a built-in run and a
    Python-sampler run: independent of what else the machine runs."""
    counts = {}
    for mode in ("setup", "builtin", "python"):
        p = subprocess.run(
            ["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null",
             sys.executable, __file__, "--one", mode, "--robot", a.robot, "--terrain",
             a.terrain, "--steps", str(a.steps), "--seed", str(a.seed)],
            capture_output=True, text=True, check=True,
        )
        counts[mode] = int(re.findall(r"Collected : (\d+)", p.stderr)[-1])
        print(f"   instructions, reference run + {mode}: {counts[mode]:,}")
    builtin = counts["builtin"] - counts["setup"]
    python = counts["python"] - counts["setup"]
    print(
        f"4. instructions of one run: built-in {builtin:,}, Python sampler {python:,}: "
        f"the Python sampler adds {100 * (python - builtin) / builtin:+.2f} % (target < 5 %)"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="warthog")
    ap.add_argument("--terrain", default="asphalt")
    ap.add_argument("--steps", type=int, default=150)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--instructions", action="store_true",
                    help="also count instructions under callgrind (valgrind; a few minutes)")
    ap.add_argument("--one", choices=["setup", "builtin", "python"], help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.one:
        one(a)
        return
    print(
        f"drive_sim {drive_sim.__version__}, Python {platform.python_version()}, "
        f"{platform.machine()}; {a.robot} on {a.terrain}, {a.steps} steps, seed {a.seed}"
    )

    # The built-in run once, to learn its commands.
    a.seed, ref = replayable(a.robot, a.terrain, a.steps, a.seed)
    print(f"seed {a.seed}")
    commands = list(zip(ref.steps["cmd_left_rad_s"], ref.steps["cmd_right_rad_s"]))

    builtin, python = [], []
    for _ in range(a.repeat):
        tb, rb = timed_run(a.robot, a.terrain, a.steps, a.seed, "uniform-wheel")
        tp, rp = timed_run(a.robot, a.terrain, a.steps, a.seed, Replay(commands))
        assert rb.steps.equals(rp.steps), "the replay simulated other steps"
        assert rb.summary["summary"] == rp.summary["summary"]
        builtin.append(tb)
        python.append(tp)
    # The time the runs spent in Python per draw (the adapter: history and the sampler's call),
    # measured inside the process: another process's load stretches it far less than the runs.
    inside = []
    call = drive_sim._Adapter.__call__

    def timed_call(self, step, rows):
        t0 = time.perf_counter()
        try:
            return call(self, step, rows)
        finally:
            inside[-1] += time.perf_counter() - t0

    drive_sim._Adapter.__call__ = timed_call
    for _ in range(a.repeat):
        inside.append(0.0)
        timed_run(a.robot, a.terrain, a.steps, a.seed, Replay(commands))
    drive_sim._Adapter.__call__ = call
    mb = statistics.median(t[0] for t in builtin)
    print(
        f"0. in Python per run: {' '.join(f'{1e3 * x:.1f}' for x in inside)} ms "
        f"(median {1e3 * statistics.median(inside):.1f} ms = "
        f"{100 * statistics.median(inside) / mb:.2f} % of the built-in run's median wall time)"
    )
    # On a shared machine other processes stretch some runs: the minimum is the run least
    # disturbed, the CPU time the process's own work.
    for i, what in enumerate(("wall", "CPU")):
        b = [t[i] for t in builtin]
        p = [t[i] for t in python]
        print(f"1. {what} s, built-in: {' '.join(f'{x:.3f}' for x in b)}")
        print(f"   {what} s, Python:   {' '.join(f'{x:.3f}' for x in p)}")
        for stat in (min, statistics.median):
            sb, sp = stat(b), stat(p)
            print(
                f"   {stat.__name__:>6}: {sb:.3f} -> {sp:.3f} s: the Python sampler adds "
                f"{100 * (sp - sb) / sb:+.2f} % (target < 5 %)"
            )

    rows = [tuple(r) for r in ref.steps.itertuples(index=False)]
    n = 200
    t0 = time.perf_counter()
    for _ in range(n):
        drive_sim._steps_frame(rows)
    per = (time.perf_counter() - t0) / n
    print(f"2. Run.steps of {len(rows)} steps built in {1e3 * per:.2f} ms (target < 50 ms)")

    h = drive_sim._History(len(rows))
    t0 = time.perf_counter()
    for r in rows:
        h.append([r])
        h.frame()
    per = (time.perf_counter() - t0) / len(rows)
    print(
        f"3. history: {1e3 * per:.3f} ms per draw to append a row and build the DataFrame "
        f"({1e3 * per * len(rows):.1f} ms over {len(rows)} draws)"
    )
    if a.instructions:
        instructions(a)


if __name__ == "__main__":
    main()
