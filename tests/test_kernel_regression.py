"""The kernel's results, pinned bit for bit: a refactor or a speed-up must not move them.

The values (float.hex) were recorded with the kernel of commit 561a52c, before its
arguments were grouped (GitHub issue 13), on x86-64 Linux with glibc's sin/cos/exp.
They cover the paths a trial can take: success at 60 s, failure at 60 s with the
chapter's printed eligibility and a soft switch, the eq-24 early end at t = 30 s, a
numerical fault, and a run with sensor noise, a model mismatch and held actions. A
libm with other roundings could move the last bits; the kernel itself must not.
"""

from __future__ import annotations

import numpy as np

from striatal.params import CHAPTER_INITIAL_W, Controller, Plant, Simulation
from striatal.sim.rollout import Protocol, SensorNoise, TrialRequest, run_trial, simulate


def _hex(values: object) -> list[str]:
    return [float(v).hex() for v in np.ravel(np.asarray(values, dtype=float))]


def test_chapter_final_simulation_is_pinned() -> None:
    t = simulate(Plant(), Controller(), Simulation(), protocol=Protocol())
    assert _hex(t.outcome.final_state) == [
        "0x1.b0af46bbbcd65p-23",
        "-0x1.9a68b36144fc3p-22",
        "0x1.8385f105231a0p-26",
        "-0x1.8d24e80718304p-31",
    ]
    assert t.outcome.reward == 10.0 and t.outcome.n_switches == 1
    assert float(t.outcome.max_abs_force).hex() == "0x1.d308c7be5077ep+3"
    assert float(t.data.sum()).hex() == "0x1.769425c31ddd6p+17"


def test_sensor_noise_mismatch_and_held_actions_are_pinned() -> None:
    t = simulate(
        Plant(),
        Controller(),
        Simulation(duration=20.0),
        rng=np.random.default_rng(4),
        model=Plant(pole_mass=1.2),
        sensor=SensorNoise(0.01, 0.02),
        action_every=3,
    )
    assert _hex(t.outcome.final_state) == [
        "-0x1.94df508e88422p-1",
        "-0x1.4b7b8a7fd5a7ap-2",
        "0x1.eaf4f087f08b9p-7",
        "-0x1.25e56f2c4ae7fp-4",
    ]
    assert float(t.data.sum()).hex() == "0x1.a4148522d1e28p+13"
    assert t.outcome.n_switches == 1


def test_failing_trial_and_its_trace_are_pinned() -> None:
    """Soft switch, printed e1, an action every 2 steps: fails eq 25 at 60 s."""
    trace = np.zeros(6)
    o = run_trial(
        TrialRequest(
            Plant(),
            Controller(CHAPTER_INITIAL_W, 0.6, switch="soft"),
            Simulation(),
            protocol=Protocol(),
            trace=trace,
            gamma=0.995,
            rng=np.random.default_rng(9),
            chapter_eligibility=True,
            action_every=2,
        )
    )
    assert (o.reward, o.early, o.fault, o.ended_at) == (-5.0, False, False, 60.0)
    assert _hex(trace) == [
        "-0x1.c5fdab569736ep-3",
        "-0x1.63c3efece07e4p+0",
        "-0x1.c3590a8cc8348p+0",
        "-0x1.110deba3b774cp-17",
        "0x1.0f9b9a80aafbdp-16",
        "0x1.89b7310d3fc6dp-1",
    ]
    assert _hex(o.final_state) == [
        "0x1.4bed5f7cccc5ap-3",
        "0x1.507d60b05d4dep-2",
        "-0x1.f18029d33b5fbp-6",
        "-0x1.b49d449044d5ep-5",
    ]


def test_early_end_at_the_check_is_pinned() -> None:
    """No swing-up energy gain (W4 = 0): still hanging at t = 30 s, eq 24 ends the trial."""
    W = np.array(CHAPTER_INITIAL_W)
    W[3] = 0.0
    trace = np.zeros(6)
    o = run_trial(
        TrialRequest(
            Plant(),
            Controller(CHAPTER_INITIAL_W, 0.6),
            Simulation(),
            protocol=Protocol(),
            trace=trace,
            gamma=0.999,
            rng=np.random.default_rng(0),
            gains=W,
        )
    )
    assert (o.reward, o.early, o.fault, o.ended_at) == (-5.0, True, False, 30.0)
    assert float(o.max_abs_x).hex() == "0x1.47c5d26785a37p-2"
    assert _hex(trace) == [
        "0x0.0p+0",
        "0x0.0p+0",
        "0x0.0p+0",
        "0x1.46c8d86fed20ap+2",
        "-0x1.4f4164c7a06edp+0",
        "-0x1.cdb4871f40549p+1",
    ]
    assert _hex(o.final_state) == [
        "-0x1.421266129410cp-2",
        "0x1.0e148d9013356p-9",
        "0x1.8f7aac12034dbp+1",
        "0x1.6d8fb3a993d6fp-2",
    ]


def test_fault_is_pinned() -> None:
    """A swing-up cart gain far beyond RK4's stability: the state blows up (fault, -5)."""
    W = np.array(CHAPTER_INITIAL_W)
    W[4] = 1.0e4
    trace = np.zeros(6)
    o = run_trial(
        TrialRequest(
            Plant(),
            Controller(CHAPTER_INITIAL_W, 0.6),
            Simulation(),
            protocol=Protocol(),
            trace=trace,
            gamma=0.999,
            rng=np.random.default_rng(1),
            gains=W,
        )
    )
    assert (o.reward, o.early, o.fault) == (-5.0, False, True)
    assert float(o.ended_at).hex() == "0x1.999999999999ap-5"
    assert float(o.max_abs_x).hex() == "0x1.ac9eaf863d95fp+14"
    assert _hex(trace) == [
        "0x0.0p+0",
        "0x0.0p+0",
        "0x0.0p+0",
        "-0x1.35dfeed3885b6p+60",
        "0x1.5c0a603fa4566p+26",
        "-0x1.3c430de5c01adp-2",
    ]
