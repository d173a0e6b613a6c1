"""The generic forward model against the one it replaced, on the same data.

    python benchmarks/forward_generic_fit.py

Fits, on two recorded 20-s trials of a plant (pole mass 0.12 kg, length 0.9 m; the
chapter's W(0) and its final W, force held), (a) ``fit_generic`` (five ridge
regressions on the cubic monomials) and (b) the same ensemble on 300 random Fourier
features of an RBF kernel (scikit-learn ``RBFSampler``, gamma 0.5, ridge 1e-6), and
prints for each the root-mean-square error of the predicted accelerations on a third
controller's trial, relative to their spread; for (a) also the wall time of an
imagined 60-s trial of the final W on the compiled kernel (the median of 20).
"""

from __future__ import annotations

import time

import numpy as np
from sklearn.kernel_approximation import RBFSampler
from sklearn.linear_model import Ridge
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from striatal.learners.forward.model import GenericModel, Transitions, _features, fit_generic
from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
)
from striatal.sim.robust import ROBUST_HARDWARE
from striatal.sim.rollout import simulate

FINAL = Controller(gains=CHAPTER_FINAL_W, theta_c=CHAPTER_FINAL_THETA_C)
INITIAL = Controller(gains=CHAPTER_INITIAL_W, theta_c=CHAPTER_INITIAL_THETA_C)
OTHER = Controller(gains=(1.0, -0.3, -0.9, 0.4, 0.5, 1.0), theta_c=0.8)
TRUE = Plant(pole_mass=0.12, length=0.9)


def recorded(controller: Controller, duration: float) -> Transitions:
    trajectory = simulate(
        TRUE, controller, Simulation(duration=duration), model=Plant(), hardware=ROBUST_HARDWARE
    )
    return Transitions.of([trajectory])


def rff(data: Transitions, rng: np.random.Generator) -> GenericModel:
    X = _features(data.states, data.forces)
    y = (data.next_states[:, [1, 3]] - data.states[:, [1, 3]]) / data.dt
    members = []
    for _ in range(5):
        rows = rng.integers(0, len(data), len(data))
        pipe = make_pipeline(
            StandardScaler(),
            RBFSampler(gamma=0.5, n_components=300, random_state=int(rng.integers(2**31 - 1))),
            Ridge(alpha=1e-6),
        )
        members.append(pipe.fit(X[rows], y[rows]))
    return GenericModel(tuple(members), data.dt)


def main() -> None:
    data = Transitions.of(
        [
            simulate(TRUE, c, Simulation(duration=20.0), model=Plant(), hardware=ROBUST_HARDWARE)
            for c in (FINAL, INITIAL)
        ]
    )
    held = recorded(OTHER, 20.0)
    acc = (held.next_states[:, [1, 3]] - held.states[:, [1, 3]]) / held.dt
    models = {
        "cubic monomials (fit_generic)": fit_generic(data, np.random.default_rng(1)),
        "300 random Fourier features": rff(data, np.random.default_rng(1)),
    }
    for name, model in models.items():
        pred = model.accelerations(held.states, held.forces).mean(axis=0)
        rel = np.sqrt(((pred - acc) ** 2).mean(axis=0)) / acc.std(axis=0)
        print(f"{name}: held-out acceleration error / spread: x {rel[0]:.4f}, theta {rel[1]:.4f}")
    model = models["cubic monomials (fit_generic)"]
    plant = model.plant()
    sim = Simulation(duration=60.0)
    simulate(plant, FINAL, sim, hardware=ROBUST_HARDWARE)
    times = []
    for _ in range(20):
        t = time.perf_counter()
        tr = simulate(plant, FINAL, sim, hardware=ROBUST_HARDWARE)
        times.append(time.perf_counter() - t)
    steps = len(tr.data) - 1
    print(
        f"imagined 60-s trial on the kernel: {1e3 * float(np.median(times)):.2f} ms "
        f"({steps} steps, {1e9 * float(np.median(times)) / steps:.0f} ns a step)"
    )


if __name__ == "__main__":
    main()
