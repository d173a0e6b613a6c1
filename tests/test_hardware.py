"""The motor and track options of :class:`striatal.params.Hardware` (docs/paper-notes.md section 9).

The force hold is checked against an independent force-level integration of eqs 8-9
(scipy's DOP853 at rtol 1e-10, the force of eq 12 computed by the NumPy reference of
the controller at each 10-ms sample and held); the integrator of the force-driven
plant conserves energy and horizontal momentum with zero force; the default (u held)
is the chapter's kernel bit for bit; a track ends a trial as its own end reason;
a force limit bounds the force the plant receives.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from striatal.errors import ParameterError
from striatal.params import CHAPTER_HARDWARE, Controller, Hardware, Plant, Simulation
from striatal.sim import kernel
from striatal.sim.control import mean_action
from striatal.sim.dynamics import force, force_level_accelerations
from striatal.sim.rollout import (
    NO_PROTOCOL,
    Protocol,
    TrialRequest,
    batch_args,
    run_trial,
    simulate,
)


def _force_level_run(
    plant: Plant,
    model: Plant,
    controller: Controller,
    sim: Simulation,
    n_steps: int,
    max_force: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """States (n_steps + 1, 4) and held forces (n_steps,) of an independent closed loop.

    At each sample k dt: u = the mean policy (NumPy, with the controller's ``model``),
    f = eq 12 with the model (clipped to ``max_force``), then eqs 8-9 of the true
    ``plant`` integrated over the step with f held by solve_ivp (DOP853, rtol 1e-10).
    """

    def rhs(_t: float, s: np.ndarray, f: float) -> np.ndarray:
        acc = force_level_accelerations(s, f, plant)
        return np.array([s[1], acc[0], s[3], acc[1]])

    s = sim.initial_state.copy()
    states = [s.copy()]
    forces = []
    for _ in range(n_steps):
        u = float(mean_action(s, controller, model))
        f = float(force(s, u, model))
        if max_force is not None:
            f = min(max(f, -max_force), max_force)
        sol = solve_ivp(rhs, (0.0, sim.dt), s, method="DOP853", rtol=1e-10, atol=1e-12, args=(f,))
        s = sol.y[:, -1].copy()
        states.append(s.copy())
        forces.append(f)
    return np.array(states), np.array(forces)


@pytest.mark.parametrize(
    ("true_plant", "max_force"),
    [
        (Plant(), None),  # the nominal plant
        (Plant().scaled(pole_mass=1.2, length=0.8), None),  # a corner of the robust set
        (Plant(), 0.1),  # a motor that saturates in the first swings (0.18 N free)
    ],
)
def test_force_hold_equals_an_independent_force_level_integration(
    true_plant: Plant, max_force: float | None
) -> None:
    """4 s of the chapter's final controller: the kernel's force-hold run equals the
    solve_ivp closed loop to 1e-6 in every state component and force.

    One RK4 step per 10-ms sample has a local error of order dt^5 on this smooth
    force-driven system; over 400 steps of the swing-up that stays below 1e-6.
    """
    model = Plant()
    controller = Controller()
    sim = Simulation(duration=4.0)
    hw = Hardware(hold="force", max_force=max_force)
    traj = simulate(true_plant, controller, sim, model=model, hardware=hw)
    states, forces = _force_level_run(true_plant, model, controller, sim, sim.n_steps, max_force)
    np.testing.assert_allclose(traj.states, states, rtol=0.0, atol=1e-6)
    np.testing.assert_allclose(traj.column("force")[:-1], forces, rtol=0.0, atol=1e-6)
    if max_force is not None:
        assert np.max(np.abs(forces)) == pytest.approx(max_force)  # the limit is reached


def test_force_hold_differs_from_u_hold_as_the_notes_say() -> None:
    """docs/paper-notes.md section 9: chapter's final W, max |x| about 6.0 m with u held
    and 8.7 m with the force held; first switch 19.55 s vs 19.56 s."""
    u = simulate(Plant(), Controller(), Simulation())
    f = simulate(Plant(), Controller(), Simulation(), hardware=Hardware(hold="force"))
    assert u.outcome.max_abs_x == pytest.approx(5.96, abs=0.01)
    assert f.outcome.max_abs_x == pytest.approx(8.66, abs=0.01)
    assert u.switch_times[0] == pytest.approx(19.55)
    assert f.switch_times[0] == pytest.approx(19.56)


def test_force_level_integrator_conserves_energy_and_momentum_with_zero_force() -> None:
    """With f = 0, eqs 8-9 conserve the total energy and the horizontal momentum."""
    p = Plant()
    M, m, l, g = p.cart_mass, p.pole_mass, p.length, p.gravity
    arr = p.as_array()

    def energy(s: tuple[float, float, float, float]) -> float:
        _, xd, th, thd = s
        kinetic = 0.5 * (M + m) * xd**2 + m * l * math.cos(th) * xd * thd + 0.5 * m * l**2 * thd**2
        return kinetic + m * g * l * math.cos(th)

    def momentum(s: tuple[float, float, float, float]) -> float:
        return (M + m) * s[1] + m * l * math.cos(s[2]) * s[3]

    s = (0.0, 0.3, 2.0, 1.5)
    e0, p0 = energy(s), momentum(s)
    for _ in range(2000):  # 20 s
        s = kernel.rk4_force_step(*s, 0.0, 0.01, arr)
    assert energy(s) == pytest.approx(e0, rel=1e-7)
    assert momentum(s) == pytest.approx(p0, rel=1e-7, abs=1e-9)
    assert abs(s[2] - 2.0) > 0.1  # the pole did move


def test_force_level_accelerations_match_the_numpy_reference() -> None:
    """The kernel's eqs 8-9 equal dynamics.force_level_accelerations (eq 10's solve)."""
    rng = np.random.default_rng(3)
    p = Plant().scaled(pole_mass=1.3, length=0.7)
    for _ in range(20):
        s = rng.normal(size=4) * [1, 2, 3, 4]
        f = float(rng.normal() * 10)
        got = kernel.force_accelerations(
            math.sin(s[2]), math.cos(s[2]), s[3], f, *p.as_array().tolist()
        )
        np.testing.assert_allclose(got, force_level_accelerations(s, f, p), rtol=1e-12)


def test_default_hardware_is_the_chapter_kernel_bit_for_bit() -> None:
    """Hardware() (u held, no limit, no track) gives the same row as the plain arguments."""
    plant, controller, sim = Plant(), Controller(), Simulation()
    a = simulate(plant, controller, sim)
    b = simulate(plant, controller, sim, hardware=CHAPTER_HARDWARE)
    assert np.array_equal(a.data, b.data)
    # a limit never reached and a track never left change nothing either
    c = simulate(plant, controller, sim, hardware=Hardware(max_force=1e6, track=1e3))
    assert np.array_equal(a.data, c.data)


def test_a_trial_that_leaves_the_track_ends_there_as_a_track_failure() -> None:
    """Final W: max |x| is about 6 m, so a 4-m track ends the trial when |x| first passes 4."""
    plant, controller, sim = Plant(), Controller(), Simulation()
    free = simulate(plant, controller, sim)
    x = free.column("x")
    first = int(np.argmax(np.abs(x) > 4.0))
    traj = simulate(plant, controller, sim, hardware=Hardware(track=4.0))
    o = traj.outcome
    assert o.track and not o.success and not o.early and not o.fault
    assert o.end_reason == "track"
    assert o.ended_at == pytest.approx(first * sim.dt)
    assert abs(traj.column("x")[-1]) > 4.0
    assert np.all(np.abs(traj.column("x")[:-1]) <= 4.0)
    # in the protocol it earns the failure reward
    o2 = run_trial(
        TrialRequest(
            plant,
            controller,
            sim,
            protocol=Protocol(),
            trace=np.zeros(6),
            gamma=0.0,
            rng=None,
            hardware=Hardware(track=4.0),
        )
    )
    assert o2.reward == Protocol().reward_failure and o2.end_reason == "track"
    # and a wide enough track changes nothing
    assert simulate(plant, controller, sim, hardware=Hardware(track=6.5)).outcome.success


@pytest.mark.parametrize("hold", ["u", "force"])
def test_a_force_limit_bounds_the_force_the_plant_gets(hold: str) -> None:
    """max |force| = 14.6 N unlimited (u held); a 5-N motor never pushes harder than 5 N.

    The plant's own accelerations confirm it: the force implied by eqs 8-9 from the
    recorded motion stays within the limit (checked by finite differences of x_dot
    and theta_dot, which are exact for the force-held step's mean acceleration only
    to O(dt), hence the 1-N slack).
    """
    plant, controller, sim = Plant(), Controller(), Simulation(duration=20.0)
    free = simulate(plant, controller, sim, hardware=Hardware(hold=hold))  # type: ignore[arg-type]
    assert free.outcome.max_abs_force > 10.0
    traj = simulate(plant, controller, sim, hardware=Hardware(hold=hold, max_force=5.0))  # type: ignore[arg-type]
    assert traj.outcome.max_abs_force == pytest.approx(5.0)
    assert np.max(np.abs(traj.column("force"))) <= 5.0
    # force implied by the motion: eq 8, f = (M + m) x_ddot + m l (c th_ddot - s th_dot^2)
    s = traj.states
    dt = sim.dt
    xdd = np.diff(s[:, 1]) / dt
    thdd = np.diff(s[:, 3]) / dt
    th, thd = s[:-1, 2], s[:-1, 3]
    M, m, l = plant.cart_mass, plant.pole_mass, plant.length
    implied = (M + m) * xdd + m * l * (np.cos(th) * thdd - np.sin(th) * thd**2)
    assert np.max(np.abs(implied)) < 6.0
    assert not np.array_equal(traj.data[:, 1], free.data[: len(traj.data), 1])


def test_hardware_validation() -> None:
    with pytest.raises(ParameterError, match="hold"):
        Hardware(hold="torque")  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="max_force"):
        Hardware(max_force=0.0)
    with pytest.raises(ParameterError, match="track"):
        Hardware(track=-1.0)
    assert Hardware().idealised and not Hardware(hold="force").idealised


def test_lockstep_refuses_the_force_hold_the_limit_and_the_track() -> None:
    sim = Simulation(duration=1.0)
    for hw in (Hardware(hold="force"), Hardware(max_force=5.0), Hardware(track=1.0)):
        args = batch_args([TrialRequest(Plant(), Controller(), sim, NO_PROTOCOL, hardware=hw)] * 2)
        with pytest.raises(ValueError, match="run_trials_batch"):
            kernel.run_trials_lockstep(*args)
        kernel.run_trials_batch(*args)  # the batch kernel runs them
        assert np.all(np.isfinite(args[-1][:, kernel.OUT_X]))
