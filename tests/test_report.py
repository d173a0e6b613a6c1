"""``striatal.load``, the :class:`Sweep` that ``striatal.sweep`` returns, and the HTML page
of ``striatal report``, checked by parsing it: its sections, one table row per arm with
the summary's numbers, images that decode, maths, and nothing fetched from elsewhere."""

from __future__ import annotations

import base64
import io
import json
import re
from html.parser import HTMLParser
from pathlib import Path

import pytest

import striatal
from striatal.errors import DataFileError
from striatal.experiments.results import ArmResult, Sweep
from striatal.experiments.sweeps import json_roundtrip
from striatal.experiments.training import Run

pytest.importorskip("jinja2")
pytest.importorskip("mathjax")


@pytest.fixture(scope="module")
def folders(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A small sweep (3 seeds, learner and control), a second one on random W(0), and a
    short training run, each in its folder."""
    root = tmp_path_factory.mktemp("report")
    made = striatal.sweep(seeds=3, max_trials=25, eval_draws=0, out=root / "sweep")
    assert isinstance(made, Sweep) and (made.ran, made.skipped) == (6, 0)
    assert made.folder == root / "sweep" and len(made.runs) == 6
    striatal.sweep(seeds=3, init="random", max_trials=25, eval_draws=0, out=root / "random")
    striatal.train(max_trials=25, seed=1, out=root / "train")
    return {"sweep": root / "sweep", "random": root / "random", "train": root / "train"}


class Page(HTMLParser):
    """The parts of a page a reader relies on."""

    def __init__(self) -> None:
        super().__init__()
        self.headings: list[str] = []
        self.images: list[dict[str, str]] = []
        self.scripts: list[dict[str, str]] = []
        self.links: list[str] = []
        self.arm_rows: list[str] = []
        self.text: list[str] = []
        self._tag: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = {k: v or "" for k, v in attrs}
        self._tag.append(tag)
        if tag == "img":
            self.images.append(a)
        elif tag == "script":
            self.scripts.append(a)
        elif tag in ("link", "a") and "href" in a:
            self.links.append(a["href"])
        elif tag == "tr" and "data-arm" in a:
            self.arm_rows.append(a["data-arm"])
        if tag in ("img", "meta", "link"):
            self._tag.pop()

    def handle_endtag(self, tag: str) -> None:
        if self._tag and self._tag[-1] == tag:
            self._tag.pop()

    def handle_data(self, data: str) -> None:
        if self._tag and self._tag[-1] in ("h1", "h2", "h3"):
            self.headings.append(data.strip())
        if not self._tag or self._tag[-1] not in ("script", "style"):
            self.text.append(data)


def parse(path: Path) -> Page:
    page = Page()
    page.feed(path.read_text(encoding="utf-8"))
    return page


def test_sweep_returns_a_sweep_with_arms_runs_and_a_plot(folders: dict[str, Path]) -> None:
    sweep = striatal.load(folders["sweep"])
    assert isinstance(sweep, Sweep)
    assert [(a.name, a.runs) for a in sweep.arms] == [("control", 3), ("learner", 3)]
    assert len(sweep.runs) == 6 and sweep.runs is sweep.rows
    saved = json.loads((folders["sweep"] / "summary.json").read_text())
    # opened from its files, the summary is the one the sweep wrote (seeded bootstrap)
    assert saved["arms"] == json_roundtrip(sweep.summary["arms"])
    for arm, stored in zip(sweep.arms, saved["arms"], strict=True):
        assert arm.success_rate == stored["success_rate"]
        assert arm.successes == sum(r["success"] for r in sweep.runs if r["arm"] == arm.name)
        assert list(arm.interval or ()) == stored["success_rate_ci"]
    fig = sweep.plot()
    title = fig.axes[0].get_title()
    assert "chapter learner from the chapter's W(0): 3 seeds (root 0)" in title
    assert "at most 25 trials" in title


def test_load_opens_a_run_folder_as_train_returned_it(folders: dict[str, Path]) -> None:
    run = striatal.load(folders["train"])
    assert isinstance(run, Run)
    again = striatal.train(max_trials=25, seed=1)
    assert (run.trials, run.W, run.theta_c, run.success) == (
        again.trials,
        again.W,
        again.theta_c,
        again.success,
    )
    assert run.history == again.history
    assert striatal.load(folders["train"] / "result.json").run_id == run.run_id


def test_load_refuses_a_folder_of_neither(tmp_path: Path, cli) -> None:
    (tmp_path / "runs.csv").write_text("arm\n")
    with pytest.raises(DataFileError, match="neither a sweep folder"):
        striatal.load(tmp_path)
    with pytest.raises(DataFileError, match="no such folder"):
        striatal.load(tmp_path / "missing")
    code, out, err = cli("report", str(tmp_path), "--out", str(tmp_path / "r.html"))
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "r.html").exists()


def test_arm_result_reads_the_summary_of_an_arm() -> None:
    arm = ArmResult.of(
        {
            "arm": "learner",
            "init": "chapter",
            "role": "learner",
            "learner": "pgpe",
            "method": "learn",
            "runs": 10,
            "successes": 7,
            "success_rate": 0.7,
            "success_rate_ci": [0.4, 0.9],
        }
    )
    assert (arm.successes, arm.interval, arm.stats["runs"]) == (7, (0.4, 0.9), 10)


def _images_decode(page: Page) -> None:
    from PIL import Image

    assert page.images
    for img in page.images:
        src = img["src"]
        assert src.startswith("data:image/png;base64,"), src[:40]
        picture = Image.open(io.BytesIO(base64.b64decode(src.split(",", 1)[1])))
        picture.verify()
        assert picture.size[0] > 300 and picture.size[1] > 200
        assert img.get("alt")


def _self_contained(page: Page) -> None:
    """Nothing the browser would fetch: inline scripts, data images, no outside links."""
    assert all("src" not in s for s in page.scripts)
    assert not [h for h in page.links if re.match(r"^(https?:)?//", h)]


def test_report_of_a_sweep(folders: dict[str, Path], cli) -> None:
    out = folders["sweep"] / "page.html"
    code, stdout, _ = cli("report", str(folders["sweep"]), "--out", str(out))
    assert code == 0 and stdout.strip() == f"wrote {out}"
    page = parse(out)
    for heading in (
        "Success per arm",
        "Each learner against its no-learning control (paired on the same seeds)",
        "Performance profiles",
        "Settings",
        "Commands",
        "How the numbers are made",
    ):
        assert heading in page.headings, heading
    assert page.arm_rows == ["control", "learner"]
    text = " ".join(page.text)
    summary = json.loads((folders["sweep"] / "summary.json").read_text())
    for arm in summary["arms"]:
        lo, hi = arm["success_rate_ci"]
        assert f"{100 * arm['success_rate']:.0f} % [{100 * lo:.0f}, {100 * hi:.0f}]" in text
    assert "striatal sweep --seeds 3" not in text  # the Python API records no options
    assert "striatal train --seed S --init INIT" in text
    # display maths for MathJax, and MathJax itself inline
    assert text.count("\\[") >= 3 and "Wilson" in text
    assert len(out.read_text()) > 1_000_000
    _images_decode(page)
    _self_contained(page)


def test_report_of_a_run_and_of_two_sweeps(folders: dict[str, Path], cli) -> None:
    out = folders["train"] / "report.html"
    assert cli("report", str(folders["train"]))[0] == 0
    page = parse(out)
    assert "Learning curves" in page.headings and "Outcome" in page.headings
    text = " ".join(page.text)
    assert "striatal train --learner chapter --init chapter --seed 1 --max-trials 25" in text
    _images_decode(page)
    _self_contained(page)

    both = folders["sweep"].parent / "both.html"
    assert cli("report", str(folders["sweep"]), str(folders["random"]), "--out", str(both))[0] == 0
    page = parse(both)
    assert "All arms of the sweeps" in page.headings
    assert page.arm_rows == ["control", "learner", "control", "learner"]
    assert len(page.images) == 3  # the comparison, then each sweep's own
    _images_decode(page)
    _self_contained(page)


def test_report_refuses_a_page_that_is_not_html(folders: dict[str, Path], cli) -> None:
    code, _, err = cli("report", str(folders["sweep"]), "--out", str(folders["sweep"] / "r.png"))
    assert code == 2 and "HTML" in err


def test_titles_name_the_setting_of_each_sweep() -> None:
    from striatal.viz.profiles import sweep_title, sweeps_title

    def settings(learner: str, inits: list[str], **more: object) -> dict[str, object]:
        arms = {"learner": {"method": "learn", "config": {"learner": learner}}}
        return {"arms": arms, "seeds": 100, "root_seed": 1, "inits": inits, **more}

    pgpe = settings("pgpe", ["random"], max_trials=300, success_on="mean")
    assert sweep_title(pgpe) == (
        "pgpe learner from random W(0): 100 seeds (root 1), at most 300 trials, "
        "success on the mean policy"
    )
    chapter = settings("chapter", ["random"], max_trials=300, success_on="mean")
    assert sweeps_title([pgpe, chapter]).startswith("pgpe and chapter learners from random")
    other = settings("chapter", ["chapter", "random"], robust="...")
    assert sweeps_title([pgpe, other]).splitlines()[1] == (
        "chapter learner from the chapter's W(0) and random W(0): 100 seeds (root 1), "
        "robust stop rule"
    )
    assert sweep_title({}) == "" and sweeps_title([{}]) == ""


def test_without_mathjax_one_line_names_the_extra(
    folders: dict[str, Path], cli, monkeypatch: pytest.MonkeyPatch
) -> None:
    import sys

    from striatal.errors import StriatalError
    from striatal.reports.assets import mathjax_script

    mathjax_script.cache_clear()
    monkeypatch.setitem(sys.modules, "mathjax", None)
    try:
        with pytest.raises(StriatalError, match=r"striatal\[report\]"):
            mathjax_script()
        out = folders["sweep"].parent / "none.html"
        code, _, err = cli("report", str(folders["sweep"]), "--out", str(out))
        assert code == 2 and "[report]" in err and len(err.strip().splitlines()) == 1
        assert not out.exists()
    finally:
        mathjax_script.cache_clear()
