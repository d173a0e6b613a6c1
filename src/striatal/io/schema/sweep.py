"""The schemas of a sweep's files: runs.csv's rows, summary.json, sweep.json and
ablation.json, and the readers of its JSON files."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from striatal.errors import DataFileError
from striatal.io.schema.common import (
    _MODEL,
    _ROW,
    MAX_COUNT,
    Count,
    CsvCount,
    CsvFlag,
    CsvNonNegative,
    CsvRate,
    CsvReal,
    CsvSeed,
    Interval,
    Name,
    NonNegative,
    Rate,
    RateInterval,
    Seed,
    validated,
)


class RunRow(BaseModel):
    """One row of runs.csv: one learning run (or baseline run) of a sweep.

    Units: simulated_seconds, imagined_seconds, first_success_seconds, wall_seconds [s];
    theta_c [rad]. The first_success columns: trials, simulations and simulated seconds
    to the run's first success (empty if none), its totals unless it learned on after it
    (margin_after_success); margin_reached: 1/0 with margin_after_success, else empty.
    """

    model_config = _ROW
    arm: Name
    role: Name
    method: Name
    learner: Name
    init: Name
    seed: CsvSeed
    alpha: CsvReal = None
    gamma: CsvReal = None
    success: CsvFlag
    trials: CsvCount
    W1: CsvReal
    W2: CsvReal
    W3: CsvReal
    W4: CsvReal
    W5: CsvReal
    W6: CsvReal
    theta_c: CsvReal
    W0_1: CsvReal
    W0_2: CsvReal
    W0_3: CsvReal
    W0_4: CsvReal
    W0_5: CsvReal
    W0_6: CsvReal
    theta_c0: CsvReal
    mean_policy_success: CsvFlag
    robust: CsvRate = None
    simulations: CsvCount
    simulated_seconds: CsvNonNegative
    eval_simulations: CsvCount
    pass_rate_W0: CsvRate = None  # noqa: N815 (the column's name in runs.csv)
    pass_rate: CsvRate = None
    wall_seconds: CsvNonNegative = None
    imagined_simulations: CsvCount = 0
    imagined_seconds: CsvNonNegative = 0.0
    settings_id: Annotated[str, Field(max_length=64, pattern=r"^[0-9a-zA-Z]*$")] = ""
    first_success_trials: CsvNonNegative = None
    first_success_simulations: CsvNonNegative = None
    first_success_seconds: CsvNonNegative = None
    margin_reached: CsvRate = None

    @model_validator(mode="after")
    def _counts(self) -> RunRow:
        if self.simulations < self.trials:
            raise ValueError(
                f"simulations ({self.simulations}) are fewer than trials ({self.trials})"
            )
        first = self.first_success_trials
        if first is not None and (not self.success or first > self.trials):
            raise ValueError(
                f"first_success_trials {first} without success or beyond trials {self.trials}"
            )
        if self.success and self.trials == 0:
            raise ValueError("success with 0 trials")
        return self


class CostRow(BaseModel):
    """The columns of a runs.csv row that a performance profile reads (a file of another
    striatal version may hold only these): the arm, its init and seed, whether it
    solved, and its costs [trials, simulations, s]."""

    model_config = ConfigDict(strict=False, extra="ignore", frozen=True)
    arm: Name
    init: str = ""
    seed: CsvSeed
    success: CsvFlag
    trials: CsvCount
    simulations: CsvCount | None = None
    simulated_seconds: CsvNonNegative = None

    @model_validator(mode="after")
    def _counts(self) -> CostRow:
        if self.simulations is not None and self.simulations < self.trials:
            raise ValueError(
                f"simulations ({self.simulations}) are fewer than trials ({self.trials})"
            )
        return self


# -- summary.json, sweep.json, ablation.json -----------------------------------------


class ArmSummary(BaseModel):
    """One arm of summary.json's ``arms``: its rate over ``runs`` seeds with its Wilson
    95 % interval, and its costs [simulations, s, trials]."""

    model_config = _MODEL
    arm: Name
    init: Name
    method: Name
    role: Name | None = None
    learner: Name | None = None
    runs: Count
    successes: Count | None = None
    success_rate: Rate | None
    success_rate_ci: RateInterval | None = None
    unsolved_share: Rate | None
    trials_median: NonNegative | None
    trials_q1: NonNegative | None = None
    trials_q3: NonNegative | None = None
    simulations_median: NonNegative | None = None
    simulations_median_ci: Interval | None = None
    simulations_iqm: NonNegative | None = None
    simulations_iqm_ci: Interval | None = None
    simulations_total: Count | None = None
    trials_total: Count | None = None
    mean_policy_success_rate: Rate | None = None
    robust_rate: Rate | None = None
    pass_rate_W0_mean: Rate | None = None  # noqa: N815 (the field's name in the file)
    pass_rate_mean: Rate | None = None
    wall_seconds_total: NonNegative | None = None
    notes: list[str] | None = None

    @model_validator(mode="after")
    def _consistent(self) -> ArmSummary:
        if self.successes is not None and self.successes > self.runs:
            raise ValueError(f"successes ({self.successes}) exceed runs ({self.runs})")
        rate = self.success_rate
        if rate is not None and self.runs == 0:
            raise ValueError("a success rate over 0 runs")
        if (
            rate is not None
            and self.successes is not None
            and abs(rate * self.runs - self.successes) > 1e-6 * max(1, self.runs)
        ):
            raise ValueError(
                f"success_rate {rate} is not successes/runs = {self.successes}/{self.runs}"
            )
        if rate is not None and self.success_rate_ci is not None:
            lo, hi = self.success_rate_ci
            if not lo - 1e-9 <= rate <= hi + 1e-9:
                raise ValueError(f"success_rate {rate} lies outside its interval [{lo}, {hi}]")
            if lo > hi:
                raise ValueError(f"success_rate_ci [{lo}, {hi}] has low > high")
        if (
            rate is not None
            and self.unsolved_share is not None
            and abs(rate + self.unsolved_share - 1) > 1e-6
        ):
            raise ValueError(
                f"unsolved_share {self.unsolved_share} is not 1 - success_rate ({rate})"
            )
        if (
            self.simulations_total is not None
            and self.trials_total is not None
            and self.simulations_total < self.trials_total
        ):
            raise ValueError(
                f"simulations_total ({self.simulations_total}) is below trials_total "
                f"({self.trials_total})"
            )
        return self


class PValue(BaseModel):
    model_config = _MODEL
    p_value: Rate | None


class McNemar(BaseModel):
    """McNemar's test on the seeds two arms share: its p-value and the discordant seeds."""

    model_config = _MODEL
    p_value: Rate | None
    only_a: Count | None = None
    only_b: Count | None = None


class _Pair(BaseModel):
    """What a learner arm's comparison with another arm holds of the learner: its rate
    (with its interval), costs over solved seeds, and both tests."""

    model_config = _MODEL
    arm: Name
    init: Name
    learner: Name | None = None
    success_rate: Rate | None
    success_rate_ci: RateInterval | None = None
    simulations_median: NonNegative | None = None
    trials_median: NonNegative | None = None
    simulated_seconds_restricted_mean: NonNegative | None = None
    fisher: PValue
    mcnemar: McNemar | None = None
    same_seeds: bool | None = None


class PairSummary(_Pair):
    """One learner-against-control comparison of summary.json (``control_``: the
    control's numbers)."""

    control: Name
    control_success_rate: Rate | None
    control_success_rate_ci: RateInterval | None = None
    control_simulations_median: NonNegative | None = None
    control_trials_median: NonNegative | None = None
    control_simulated_seconds_restricted_mean: NonNegative | None = None


class BaselinePair(_Pair):
    """One learner-against-baseline comparison of summary.json (``baseline_``: the
    baseline's numbers)."""

    simulated_seconds_restricted_mean: NonNegative | None
    baseline: Name
    baseline_success_rate: Rate | None
    baseline_success_rate_ci: RateInterval | None = None
    baseline_simulations_median: NonNegative | None = None
    baseline_trials_median: NonNegative | None = None
    baseline_simulated_seconds_restricted_mean: NonNegative | None


class SweepModel(BaseModel):
    """sweep.json: the settings of a sweep (what every run of its folder computes).

    A sweep reruns only with settings equal to these, so any change is refused there;
    this schema holds the types of the fields a reader takes from it.
    """

    model_config = _MODEL
    command: Literal["striatal sweep", "striatal ablation", "striatal neural"] | None = None
    seeds: Count | list[Seed] | None = None
    max_trials: Annotated[int, Field(ge=1, le=MAX_COUNT)] | None = None
    eval_draws: Count | None = None
    arms: dict[Name, dict[str, Any]] | None = None
    root_seed: Seed | None = None
    run_seeds: list[Seed] | None = None
    inits: Annotated[list[Literal["chapter", "random"]], Field(min_length=1)] | None = None
    success_on: Name | None = None
    #: sweep.json holds the robust stop rule's note (its text), only when the rule is set
    robust: bool | Annotated[str, Field(min_length=1, max_length=2_000)] | None = None

    @model_validator(mode="after")
    def _seeds(self) -> SweepModel:
        if (
            self.run_seeds is not None
            and isinstance(self.seeds, int)
            and len(self.run_seeds) != self.seeds
        ):
            raise ValueError(f"run_seeds holds {len(self.run_seeds)} seeds, not {self.seeds}")
        return self


class SummaryModel(BaseModel):
    """summary.json of a sweep (or an ablation): its arms, comparisons, notes, settings."""

    model_config = _MODEL
    arms: Annotated[list[ArmSummary], Field(max_length=100_000)]
    learner_vs_control: list[PairSummary] = []
    learner_vs_baselines: list[BaselinePair] = []
    notes: list[str] = []
    settings: SweepModel = SweepModel()

    @model_validator(mode="after")
    def _unique(self) -> SummaryModel:
        seen: set[tuple[str, str]] = set()
        for a in self.arms:
            if (a.arm, a.init) in seen:
                raise ValueError(f"arm {a.arm!r} (init {a.init!r}) appears twice")
            seen.add((a.arm, a.init))
        return self


class AblationRun(BaseModel):
    model_config = _MODEL
    seed: Seed
    success: bool
    trials: Count
    simulations: Count
    simulated_seconds: NonNegative


class AblationVariant(BaseModel):
    model_config = _MODEL
    options: str
    runs: list[AblationRun]

    @model_validator(mode="after")
    def _unique(self) -> AblationVariant:
        seeds = [r.seed for r in self.runs]
        if len(set(seeds)) != len(seeds):
            raise ValueError("a seed appears twice")
        return self


class AblationModel(BaseModel):
    """ablation.json: each variant's options and runs (seed order)."""

    model_config = ConfigDict(strict=True, frozen=True)
    variants: dict[Name, AblationVariant]

    @classmethod
    def of(cls, data: Mapping[str, Any], where: str) -> AblationModel:
        """The variants of an ablation.json object (its keys other than settings)."""
        variants = {k: v for k, v in data.items() if isinstance(v, dict) and "runs" in v}
        return validated(cls, {"variants": variants}, where)


# -- the readers of the JSON files of a sweep ----------------------------------------


def read_summary(path: str | Path, *, what: str = "sweep summary") -> dict[str, Any]:
    """A sweep's summary.json (``path`` the file or its folder), checked against
    :class:`SummaryModel`; the parsed object (every command that reads one calls this)."""
    from striatal.io.files import read_json

    p = Path(path)
    p = p / "summary.json" if p.is_dir() else p
    data = read_json(p, what=what)
    if not isinstance(data, dict) or "arms" not in data:
        raise DataFileError(f"{what} {p} is not the summary.json of a striatal sweep")
    validated(SummaryModel, data, f"{what} {p}")
    return data


def read_sweep_settings(path: str | Path) -> dict[str, Any]:
    """A sweep's sweep.json, checked against :class:`SweepModel`; the parsed object."""
    from striatal.io.files import read_json

    p = Path(path)
    data = read_json(p, what="sweep settings")
    validated(SweepModel, data, f"sweep settings {p}")
    return dict(data)
