"""A sampler written in Python, compared with the built-in ones on one budget.

The Python sampler ("maximin") draws 32 candidate commands uniformly in the robot's command
space U and keeps the one farthest from every command already completed (read from the run's
history, a DataFrame of the completed steps), so that a short run covers U evenly. Each
sampler gets the same robot, terrain, seed and number of steps; the table shows the protocol's
cost (interruptions, time efficiency) and what the analysis gets out of the run (analysed
steps, median rho and its 95 % interval width, the share of U the commands reached).

Run from the repository root after `pip install .` (or `maturin develop`):

    python examples/python_sampler.py [--robot warthog] [--terrain gravel] [--steps 60]
"""

import argparse
import time

import numpy as np

import drive_sim


class Maximin:
    """Farthest-point sampling in the wheel frame, inside U."""

    def __init__(self, robot: str, seed: int, candidates: int = 32):
        row = drive_sim.robots().set_index("name").loc[robot]
        self.r = float(row["wheels.radius_m"])
        self.b = float(row["wheels.baseline_m"])
        self.w_max = float(row["powertrain.max_wheel_rad_s"])
        self.v_max = float(row["limits.max_lin_m_s"])
        self.wz_max = float(row["limits.max_ang_rad_s"])
        self.rng = np.random.default_rng(seed)
        self.candidates = candidates

    def _in_u(self, left: np.ndarray, right: np.ndarray) -> np.ndarray:
        vx = self.r * (left + right) / 2
        wz = self.r * (right - left) / self.b
        return (
            (np.abs(left) <= self.w_max)
            & (np.abs(right) <= self.w_max)
            & (np.abs(vx) <= self.v_max)
            & (np.abs(wz) <= self.wz_max)
        )

    def _draw(self, n: int) -> np.ndarray:
        out = np.empty((0, 2))
        while len(out) < n:
            c = self.rng.uniform(-self.w_max, self.w_max, size=(4 * n, 2))
            out = np.vstack([out, c[self._in_u(c[:, 0], c[:, 1])]])
        return out[:n]

    def next_command(self, history):
        cands = self._draw(self.candidates)
        if len(history) == 0:
            left, right = cands[0]
            return float(left), float(right)
        done = history[["cmd_left_rad_s", "cmd_right_rad_s"]].to_numpy()
        d = np.linalg.norm(cands[:, None, :] - done[None, :, :], axis=2).min(axis=1)
        left, right = cands[int(np.argmax(d))]
        return float(left), float(right)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="warthog")
    ap.add_argument("--terrain", default="gravel")
    ap.add_argument("--steps", type=int, default=60)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="out/python_sampler")
    a = ap.parse_args()

    contenders = [("python maximin", Maximin(a.robot, a.seed))] + [
        (name, name) for name in ("uniform-wheel", "halton", "boundary-aware")
    ]
    print(
        f"{a.robot} on {a.terrain}, {a.steps} steps, seed {a.seed}\n"
        f"{'sampler':<16} {'wall s':>6} {'interr':>6} {'eff %':>6} {'steps':>5} "
        f"{'rho med':>7} {'CI width':>8} {'T/U W %':>7}"
    )
    for label, sampler in contenders:
        t0 = time.perf_counter()
        run = drive_sim.run(
            a.robot, a.terrain, a.steps, seed=a.seed, sampler=sampler,
            out=a.out, name=label.replace(" ", "_"), force=True,
        )
        wall = time.perf_counter() - t0
        d = drive_sim.analyze(run.log).summary["datasets"][0]
        rho = d["stats"]["rho"] or {}
        ci = d["median_ci95"]["rho"] or {}
        s = run.summary["summary"]
        print(
            f"{label:<16} {wall:>6.1f} {s['interruptions']:>6} "
            f"{100 * s['time_efficiency']:>6.1f} {d['steps_analysed']:>5} "
            f"{rho.get('median', float('nan')):>7.3f} "
            f"{ci.get('upper', float('nan')) - ci.get('lower', float('nan')):>8.3f} "
            f"{d['t_area_pct_wheels']:>7.1f}"
        )


if __name__ == "__main__":
    main()
