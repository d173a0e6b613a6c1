"""The neural reading of section 4: coefficients from W, pathway labels, LTP/LTD counts."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from striatal.cli import main
from striatal.errors import ParameterError
from striatal.learners.state import history_columns
from striatal.neural import interpret
from striatal.params import CHAPTER_FINAL_W, CHAPTER_INITIAL_W, Plant
from striatal.sim.control import balancing_mean, swingup_mean
from striatal.sim.dynamics import energy_error

HISTORY_COLUMNS = history_columns(("sigma",))


def _coefs(terms: tuple[interpret.Term, ...]) -> dict[str, float]:
    return {t.signal: t.coefficient for t in terms}


def test_chapter_final_mu1_coefficients() -> None:
    c = _coefs(interpret.balancing_terms(CHAPTER_FINAL_W, Plant()))
    assert c["theta"] == pytest.approx((1 + 1.1736) * 9.8) == pytest.approx(21.30128)
    assert (
        c["theta_dot"]
        == pytest.approx(2 * math.sqrt(1.1736 * 9.8))
        == pytest.approx(6.7827, abs=1e-4)
    )
    assert c["x"] == pytest.approx(0.3092) and c["x_dot"] == pytest.approx(0.8027)
    printed = interpret.CHAPTER_PRINTED_MU1
    assert c["x"] == pytest.approx(printed["x"], abs=0.005)
    assert c["x_dot"] == pytest.approx(printed["x_dot"], abs=0.005)
    chapter = _coefs(interpret.balancing_terms(CHAPTER_FINAL_W, Plant(), sign=-1.0))
    assert chapter["theta"] == -c["theta"] and chapter["theta_dot"] == -c["theta_dot"]
    assert chapter["x"] == c["x"] and chapter["x_dot"] == c["x_dot"]


def test_printed_mu1_theta_terms_come_from_the_printed_w6_not_w1() -> None:
    """docs/paper-notes.md section 1: the printed final W has W1 and W6 swapped.

    Section 4's mu_1 theta terms 21.5 and 6.84 are (1 + W1 l) g and 2 l sqrt(W1 g)
    for W1 = 1.1945, the printed W6, to the printed three digits; the printed
    W1 = 1.1736 gives 21.30 and 6.78, which do not round to them.
    """
    printed = interpret.CHAPTER_PRINTED_MU1
    W = list(CHAPTER_FINAL_W)
    swapped = [W[5], *W[1:5], W[0]]
    as_printed = _coefs(interpret.balancing_terms(W, Plant()))
    as_swapped = _coefs(interpret.balancing_terms(swapped, Plant()))
    assert round(abs(as_swapped["theta"]), 1) == abs(printed["theta"]) == 21.5
    assert round(abs(as_swapped["theta_dot"]), 2) == abs(printed["theta_dot"]) == 6.84
    assert round(abs(as_printed["theta"]), 1) == 21.3 != abs(printed["theta"])
    assert round(abs(as_printed["theta_dot"]), 2) == 6.78 != abs(printed["theta_dot"])
    # the cart terms do not involve W1 and agree with the print either way
    for key in ("x", "x_dot"):
        assert as_swapped[key] == as_printed[key] == pytest.approx(printed[key], abs=0.005)


def test_chapter_final_mu2_coefficients_match_the_print() -> None:
    c = _coefs(interpret.swingup_terms(CHAPTER_FINAL_W))
    assert c["energy_pump"] == pytest.approx(0.3563)
    assert c["x"] == pytest.approx(-(0.2949**2) / 4)
    assert c["x_dot"] == pytest.approx(-0.2949)
    for k, v in interpret.CHAPTER_PRINTED_MU2.items():
        assert c[k] == pytest.approx(v, abs=0.005)


def test_pathway_labels_follow_the_sign() -> None:
    mu1 = interpret.balancing_terms(CHAPTER_FINAL_W, Plant())
    assert [t.pathway for t in mu1] == ["direct"] * 4
    mu1_printed = interpret.balancing_terms(CHAPTER_FINAL_W, Plant(), sign=-1.0)
    assert [t.pathway for t in mu1_printed] == ["indirect", "indirect", "direct", "direct"]
    mu2 = interpret.swingup_terms(CHAPTER_FINAL_W)
    assert [t.pathway for t in mu2] == ["direct", "indirect", "indirect"]
    assert interpret.pathway(0.0) == "silent"


@pytest.mark.parametrize("sign", [1.0, -1.0])
@pytest.mark.parametrize(
    "W", [CHAPTER_FINAL_W, CHAPTER_INITIAL_W, (0.3, 0.5, -0.2, 1.1, -0.4, 0.0)]
)
def test_linear_forms_equal_the_controllers(W: tuple[float, ...], sign: float) -> None:
    """The printed linear forms are the controllers of control.py, not a second copy."""
    plant = Plant(length=0.7, gravity=9.81)
    rng = np.random.default_rng(0)
    states = rng.uniform([-2, -2, -0.8, -3], [2, 2, 0.8, 3], size=(50, 4))
    Wa = np.asarray(W)
    c1 = _coefs(interpret.balancing_terms(W, plant, sign))
    lin1 = c1["theta"] * states[:, 2] + c1["theta_dot"] * states[:, 3]
    lin1 += c1["x"] * states[:, 0] + c1["x_dot"] * states[:, 1]
    np.testing.assert_allclose(lin1, balancing_mean(states, Wa, plant, sign), rtol=1e-12)
    c2 = _coefs(interpret.swingup_terms(W))
    pump = energy_error(states, plant) * states[:, 3] * np.cos(states[:, 2])
    lin2 = c2["energy_pump"] * pump + c2["x"] * states[:, 0] + c2["x_dot"] * states[:, 1]
    np.testing.assert_allclose(lin2, swingup_mean(states, Wa, plant), rtol=1e-12, atol=1e-12)


def test_linear_form_text() -> None:
    form = interpret.linear_form("mu_1", interpret.balancing_terms(CHAPTER_FINAL_W, Plant()))
    assert form == "mu_1 = 21.3 θ + 6.783 θ̇ + 0.3092 x + 0.8027 ẋ"


# --------------------------------------------------------------------------- LTP / LTD

# Four trials by hand: W1 up after a burst, W2 down after a burst, then a dip with
# W1 down and W3 up, then a burst that leaves every gain alone.
HAND_W = np.array(
    [
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [1.5, -0.5, 0.0, 0.0, 0.0, 0.0],
        [1.2, -0.5, 0.3, 0.0, 0.0, 0.0],
        [1.2, -0.5, 0.3, 0.0, 0.0, 0.0],
    ]
)
HAND_R = np.array([10.0, -5.0, 10.0, -5.0])


def test_plasticity_table_by_hand() -> None:
    table = {p.weight: p for p in interpret.plasticity_table(HAND_W, HAND_R)}
    w1, w2, w3, w4 = table["W1"], table["W2"], table["W3"], table["W4"]
    assert (w1.ltp_after_burst, w1.ltd_after_burst, w1.ltp_after_dip, w1.ltd_after_dip) == (
        1,
        0,
        0,
        1,
    )
    assert (w2.ltp_after_burst, w2.ltd_after_burst, w2.ltp_after_dip, w2.ltd_after_dip) == (
        0,
        1,
        0,
        0,
    )
    assert (w3.ltp_after_dip, w3.ltd_after_dip, w3.unchanged) == (1, 0, 2)
    assert w4.unchanged == 3 and w4.ltp_after_burst == w4.ltd_after_dip == 0
    # every one of the n - 1 updates is counted once per gain
    for p in table.values():
        total = p.ltp_after_burst + p.ltd_after_burst + p.ltp_after_dip + p.ltd_after_dip
        assert total + p.unchanged == 3
    with pytest.raises(ParameterError):
        interpret.plasticity_table(HAND_W[:, :5], HAND_R)


def _write_run(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    lines = [",".join(HISTORY_COLUMNS)]
    for k, (w, r) in enumerate(zip(HAND_W, HAND_R, strict=True)):
        row = [k + 1, r, *w, 0.6, 0.6, "", 60.0, 0, 0, 0]
        lines.append(",".join(map(str, row)))
    (folder / "history.csv").write_text("\n".join(lines) + "\n")
    result = {
        "success": True,
        "trials": 4,
        "W": list(CHAPTER_FINAL_W),
        "theta_c": 0.9035,
        "seed": 0,
        "wall_seconds": 1.0,
        "learner": "chapter",
        "settings": {
            "controller": {"balance_sign": "corrected", "switch": "hard", "inhibition": 50.0},
            "plant": {"cart_mass": 1.0, "pole_mass": 0.1, "length": 1.0, "gravity": 9.8},
        },
    }
    (folder / "result.json").write_text(json.dumps(result))
    return folder / "result.json"


def test_interpret_cli_json_reads_result_and_history_beside_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    res = _write_run(tmp_path / "run")
    assert main(["interpret", "--result", str(res), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    coefs = {t["signal"]: t["coefficient"] for t in out["mu_1"]["terms"]}
    assert coefs["theta"] == pytest.approx(21.30128) and coefs["x_dot"] == pytest.approx(0.8027)
    assert out["plasticity"]["updates"] == 3
    w1 = out["plasticity"]["per_gain"][0]
    assert (w1["ltp_after_burst"], w1["ltd_after_dip"]) == (1, 1)
    assert "-21.5" in out["sign_note"]


def test_interpret_cli_human_chapter_final(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["interpret", "--chapter-final"]) == 0
    text = capsys.readouterr().out
    assert "+21.3013" in text and "+6.7827" in text and "+0.3092" in text and "+0.8027" in text
    assert "direct (excitatory)" in text and "indirect (inhibitory)" in text
    assert "-21.5 theta" in text  # the chapter's printed form is named
    assert "plasticity" not in text


def test_interpret_cli_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    res = _write_run(tmp_path / "run")
    assert main(["interpret", "--result", str(res), "--chapter-final"]) == 2
    (tmp_path / "broken.json").write_text('{"W": [1, 2, 3]}')
    assert main(["interpret", "--result", str(tmp_path / "broken.json")]) == 2
    assert main(["interpret", "--history", str(tmp_path / "none.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 3 and "none.csv" in err
    assert main(["interpret", "--chapter-final", "--theta-c", "4"]) == 2
    assert "theta_c" in capsys.readouterr().err


def test_swingup_terms_are_the_kernels_eq23_coefficients() -> None:
    """interpret reads mu_2's coefficients from the law the compiled kernel runs."""
    from striatal.sim.kernel import swingup_coefficients, swingup_law

    W = (0.7, -0.2, 0.4, 1.3, -0.8, 0.1)
    c = _coefs(interpret.swingup_terms(W))
    assert (c["energy_pump"], c["x"], c["x_dot"]) == swingup_coefficients(W[3], W[4])
    assert (c["x"], c["x_dot"]) == pytest.approx((-0.16, 0.8))
    # the compiled law is that linear form on (E~ theta_dot cos theta, x, x_dot)
    x, x_dot, theta_dot, cos_th, m, length, g = 0.3, -0.5, 2.0, 0.6, 0.1, 1.0, 9.8
    mu_2, e_tilde = swingup_law(x, x_dot, theta_dot, cos_th, W[3], W[4], m, length, g)
    pump = e_tilde * theta_dot * cos_th
    assert mu_2 == pytest.approx(c["energy_pump"] * pump + c["x"] * x + c["x_dot"] * x_dot)
