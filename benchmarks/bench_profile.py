"""Where one 60-s trial's time goes: noise generation, the kernel, the Python wrapper.

    python benchmarks/bench_profile.py

Best of 7 repeats of 200 calls each, after a warm-up call; one thread.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from striatal.bench import measure
from striatal.params import CHAPTER_FINAL_THETA_C, CHAPTER_FINAL_W, Controller, Plant, Simulation
from striatal.sim import bench, kernel, rollout


def best_seconds(fn: Callable[[], object], calls: int = 200, repeats: int = 7) -> float:
    """Best mean seconds per call over ``repeats`` timed loops of ``calls`` calls."""
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(calls):
            fn()
        times.append((time.perf_counter() - t0) / calls)
    return min(times)


def main() -> None:
    rng = np.random.default_rng(0)
    setup = bench.TrialSetup.chapter(60.0, 0.01)
    out = np.empty(kernel.N_OUT)
    measure.first_calls(rng)
    fixed_noise = rng.standard_normal(setup.n_steps)

    def direct(noise: np.ndarray) -> None:
        bench.run_kernel_trial(setup, noise, out)

    plant = Plant()
    controller = Controller(CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C)
    sim = Simulation()
    rows = {
        f"rng.standard_normal({setup.n_steps})": lambda: rng.standard_normal(setup.n_steps),
        "kernel.run_trial, noise given": lambda: direct(fixed_noise),
        "kernel.run_trial, mean policy (no noise)": lambda: direct(np.empty(0)),
        "bench.run_scalar_trial (noise drawn + kernel)": lambda: bench.run_scalar_trial(
            setup, rng, out
        ),
        "rollout.TrialRequest.run (dataclass wrapper, noise drawn)": lambda: rollout.TrialRequest(
            plant, controller, sim, rollout.Protocol(), gamma=bench.TRACE_GAMMA, rng=rng
        ).run(),
    }
    for name, fn in rows.items():
        t = best_seconds(fn)
        print(f"{t * 1e6:9.1f} us/trial {t / setup.n_steps * 1e9:7.1f} ns/step  {name}")


if __name__ == "__main__":
    main()
