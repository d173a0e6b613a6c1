"""``striatal bench --anchors``: the kernel beside JAX (gymnax) and C++ (EnvPool) simulators.

Each anchor is timed alternately with the kernel figure it is compared with, in the
same process, warm-up (JIT compilation, first reset) excluded, best of the repeats:

- ``gymnax_1``: gymnax ``CartPole-v1``, one env, ``jit(scan)`` over one trial's steps
  (Euler, fixed action 1, auto-reset), against ``kernel.run_trial`` (one thread);
- ``gymnax_B``: the same under ``jit(vmap(scan))`` over B envs, against
  ``kernel.run_trials_lockstep`` at the same B;
- ``envpool_cartpole``: EnvPool ``CartPole-v1`` (C++, B envs, synchronous
  ``step``), against the lockstep kernel at the same B;
- ``envpool_dmc_swingup``: EnvPool ``CartpoleSwingup-v1`` (DeepMind Control on
  MuJoCo, B envs), against the lockstep kernel at the same B.

EnvPool is the optional ``[bench]`` extra. gymnax is not in it: every gymnax release
requires gymnasium < 1.4, which the extra would downgrade striatal's gymnasium to, so
gymnax is installed beside it by hand (:data:`GYMNAX_INSTALL`) and, when it is missing,
the two gymnax rows are skipped with that reason (:func:`gymnax_missing`).
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable
from typing import Any

import numpy as np

from striatal.bench.timing import BenchConfig, Comparison, compare
from striatal.errors import ParameterError
from striatal.sim import kernel
from striatal.sim.bench import TrialSetup, run_batch_trials, run_scalar_trial

__all__ = ["GYMNAX_INSTALL", "INSTALL", "NEEDED", "check_installed", "gymnax_missing", "measure"]

#: What ``--anchors`` cannot run without: the ``[bench]`` extra.
NEEDED = ("envpool",)
INSTALL = (
    "striatal bench --anchors needs the [bench] extra: pip install 'striatal[bench]' "
    "(in a source checkout: pip install -e '.[bench]')"
)
#: What the gymnax rows need beyond the extra, and how to install it without letting
#: gymnax's requirement (gymnasium < 1.4) replace striatal's gymnasium.
GYMNAX_NEEDED = ("jax", "gymnax", "flax", "seaborn", "six")
GYMNAX_INSTALL = (
    "pip install 'jax[cpu]>=0.6,<0.12' flax seaborn six && pip install --no-deps 'gymnax>=1.0,<2'"
)


def _missing(names: tuple[str, ...]) -> list[str]:
    return [name for name in names if importlib.util.find_spec(name) is None]


def check_installed() -> None:
    """ParameterError (one line) naming what to install when EnvPool is missing."""
    missing = _missing(NEEDED)
    if missing:
        raise ParameterError(f"{INSTALL} (missing: {', '.join(missing)})")


def gymnax_missing() -> str | None:
    """Why the gymnax rows cannot run (one line), or None when they can."""
    missing = _missing(GYMNAX_NEEDED)
    if not missing:
        return None
    return (
        f"gymnax rows skipped: {', '.join(missing)} not installed (gymnax requires gymnasium "
        f"< 1.4, so the [bench] extra leaves it out; to add it: {GYMNAX_INSTALL})"
    )


def _gymnax_runner(n_envs: int, n_steps: int) -> Any:
    """A jitted rollout of gymnax CartPole-v1 (action 1) returning env-steps run."""
    import gymnax
    import jax
    import jax.numpy as jnp

    env, params = gymnax.make("CartPole-v1")

    def one_env(key: Any) -> Any:
        _, state = env.reset(key, params)

        def body(carry: Any, _: Any) -> Any:
            key, state = carry
            key, sub = jax.random.split(key)
            _, state, reward, _, _, _ = env.step(sub, state, 1, params)
            return (key, state), reward

        (_, state), rewards = jax.lax.scan(body, (key, state), None, length=n_steps)
        return rewards.sum()

    if n_envs == 1:
        fn = jax.jit(one_env)
        key = jax.random.PRNGKey(0)
    else:
        fn = jax.jit(jax.vmap(one_env))
        key = jax.random.split(jax.random.PRNGKey(0), n_envs)

    def run() -> int:
        jnp.asarray(fn(key)).block_until_ready()
        return n_envs * n_steps

    return run


def _envpool_runner(task: str, n_envs: int, n_steps: int) -> Any:
    """EnvPool ``task`` with ``n_envs`` envs stepped synchronously ``n_steps`` times."""
    import envpool

    if task == "CartPole-v1":
        env = envpool.make(task, env_type="gymnasium", num_envs=n_envs, batch_size=n_envs)
        actions = np.ones(n_envs, dtype=np.int32)
    else:
        env = envpool.make(task, env_type="dm", num_envs=n_envs, batch_size=n_envs)
        actions = np.zeros((n_envs, 1), dtype=np.float64)
    env.reset()

    def run() -> int:
        for _ in range(n_steps):
            env.step(actions)
        return n_envs * n_steps

    return run


def measure(config: BenchConfig, rng: np.random.Generator) -> dict[str, Any]:
    """Every anchor against its kernel figure; the gymnax rows only when :func:`gymnax_missing`
    is None (``versions`` names what ran)."""
    check_installed()
    with_gymnax = gymnax_missing() is None
    B = config.batch_size
    setup = TrialSetup.chapter(config.duration, config.dt)
    n = setup.n_steps
    out = np.empty(kernel.N_OUT)
    outs = np.empty((B, kernel.N_OUT))

    def scalar() -> int:
        return run_scalar_trial(setup, rng, out)

    def batch() -> int:
        return run_batch_trials(setup, B, rng, outs)

    lock_name = f"kernel.run_trials_lockstep (B={B}) + bench.batch_normals"
    rows: dict[str, tuple[str, Callable[[], int], str, Callable[[], int]]] = {}
    if with_gymnax:
        rows["gymnax_1"] = (
            "kernel.run_trial + rng.standard_normal",
            scalar,
            "gymnax CartPole-v1, 1 env, jit(scan)",
            _gymnax_runner(1, n),
        )
        rows["gymnax_B"] = (
            lock_name,
            batch,
            f"gymnax CartPole-v1, {B} envs, jit(vmap(scan))",
            _gymnax_runner(B, n),
        )
    rows["envpool_cartpole"] = (
        lock_name,
        batch,
        f"envpool CartPole-v1, {B} envs, synchronous step",
        _envpool_runner("CartPole-v1", B, n),
    )
    rows["envpool_dmc_swingup"] = (
        lock_name,
        batch,
        f"envpool CartpoleSwingup-v1 (DMC, MuJoCo), {B} envs, synchronous step",
        _envpool_runner("CartpoleSwingup-v1", B, n),
    )
    result: dict[str, Any] = {}
    for key, (k_name, k_run, r_name, r_run) in rows.items():
        k, r = compare(k_name, k_run, r_name, r_run, config)
        result[key] = Comparison(kernel=k, reference=r, target_ratio=1.0).to_dict()
    import envpool

    versions: dict[str, Any] = {"jax": None, "gymnax": None, "envpool": envpool.__version__}
    versions["jax_devices"] = []
    if with_gymnax:
        import gymnax
        import jax

        versions["jax"] = jax.__version__
        versions["gymnax"] = getattr(gymnax, "__version__", "unknown")
        versions["jax_devices"] = [str(d) for d in jax.devices()]
    result["versions"] = versions
    return result
