"""`boundid excitation` and `boundid report`'s excitation page: the page is written and linked from the
site index, its numbers are the comparison's own; a study the search cannot serve is refused in one
line, exit 2. References: the comparison computed here in-process (boundid.studies.excitation)."""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd

from boundid.cli import main
from boundid.studies.config import load_study

STUDIES = Path(__file__).resolve().parents[1] / "studies"


def _short_dd(tmp_path: Path) -> Path:
    """The direct-drive study, 3 s, 2 candidates."""
    text = (STUDIES / "direct_drive_rls.toml").read_text()
    text = text.replace("duration_s = 10.0", "duration_s = 3.0")
    text = re.sub(r"(?m)^candidates = \d+", "candidates = 2", text)
    path = tmp_path / "dd.toml"
    path.write_text(text)
    return path


def test_the_excitation_command_writes_the_page_and_the_index_links_it(tmp_path, capsys):
    study = _short_dd(tmp_path)
    assert load_study(study).experiment.design.compare
    assert main(["excitation", str(study), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    page = tmp_path / "out" / "excitation" / "index.html"
    assert capsys.readouterr().out.strip().endswith(str(page))
    html = page.read_text()
    assert "Excitation design: guaranteed against classical criteria" in html
    summary = pd.read_csv(page.parent / "tables" / "direct-drive-rls-summary.csv", index_col=0)
    assert list(summary.index) == ["first draw", "guaranteed", "cond", "logdet"]
    # the guaranteed pick has the smallest search score among the candidates drawn
    assert (summary["design width (search)"] >= summary.loc["guaranteed", "design width (search)"]).all()
    assert summary["truth in exact bounds"].all()
    index = (tmp_path / "out" / "index.html").read_text()
    assert 'href="excitation/index.html"' in index and "Excitation design" in index


def test_a_measured_study_is_refused_in_one_line(tmp_path, capsys):
    study = STUDIES / "examples" / "measured_direct_drive.toml"
    code = main(["excitation", str(study), "--out", str(tmp_path), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert err[0].startswith("boundid: error: ") and "recording" in err[0] and "excitation" in err[0]


def test_pooled_design_widths_lie_below_every_candidates(tmp_path):
    """The pooled design set (every candidate's rows) lies inside each candidate's, so its widths are
    at most each candidate's (reference: the candidates' own design widths from the search)."""
    from boundid.studies.excitation import compare_criteria
    from boundid.studies.registry import make_robot

    cfg = load_study(_short_dd(tmp_path))
    cmp = compare_criteria(cfg, make_robot(cfg.robot, cfg.robot_options))
    assert cmp.pooled is not None and cmp.pooled.shape == (len(cmp.names),)
    assert (cmp.pooled <= cmp.design.search.widths.min(axis=0) + 1e-9).all()
    # a parameter the pooled rows leave at the prior width, no single candidate narrows
    for name in cmp.not_guaranteed():
        assert (cmp.design.search.widths[:, cmp.names.index(name)] >= 0.99 - 1e-9).all()


def _with(tmp_path: Path, source: Path, old: str, new: str) -> Path:
    text = source.read_text()
    assert old in text, old
    path = tmp_path / f"edited_{len(list(tmp_path.iterdir()))}.toml"
    path.write_text(text.replace(old, new, 1))
    return path


def test_design_settings_the_experiment_cannot_give_are_refused_in_one_line(tmp_path, capsys):
    """A design rate above the sample rate, a rate that does not divide the open-loop experiment's,
    a search over the resource budget, the design keys in a study that reads a recording: exit 2,
    one line naming the key and the fix."""
    dd = _short_dd(tmp_path)
    measured = STUDIES / "examples" / "measured_direct_drive.toml"
    cases = [
        (_with(tmp_path, dd, "rate_hz = 10.0", "rate_hz = 1000.0"), r"rate_hz = 1000 Hz is above .* 400 Hz"),
        (_with(tmp_path, dd, "rate_hz = 10.0", "rate_hz = 7.0"), r"does not divide .* 400 Hz"),
        (_with(tmp_path, dd, "candidates = 2", "candidates = 10000\nrate_hz = 400.0").read_text()
         .replace("rate_hz = 10.0\n", ""), r"experiment\.design .*budget|BOUNDID_MAX"),
        (_with(tmp_path, measured, 'source = "measured"', 'source = "measured"\nexcitation = "guaranteed"'),
         r"experiment\.excitation: designs the excitation of a simulated experiment"),
    ]
    for study, match in cases:
        if isinstance(study, str):
            path = tmp_path / "budget.toml"
            path.write_text(study)
            study = path
        assert main(["run", str(study), "--out", str(tmp_path / "out"), "--quiet"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("boundid: error: "), err
        assert re.search(match, err[0]), err[0]


def test_a_campaign_replicate_runs_on_the_designed_excitation(tmp_path, monkeypatch):
    """A study with excitation = "guaranteed": each campaign replicate simulates the search's pick
    (reference: the design computed here), never the experiment's own torques."""
    from boundid.studies import campaign
    from boundid.studies.excitation import design_excitation
    from boundid.studies.registry import make_robot
    from boundid.studies.scenarios import load_campaign

    study = _with(tmp_path, _short_dd(tmp_path), 'source = "simulate"',
                  'source = "simulate"\nexcitation = "guaranteed"')
    cfg = load_study(study)
    seen = []

    def capture(ccfg, model, rng, excitation=None):
        seen.append(excitation)
        raise RuntimeError("captured")

    monkeypatch.setattr(campaign, "acquire", capture)
    scenario = load_campaign(cfg).scenarios[0]
    try:
        campaign.replicate_rows(cfg, scenario, 0)
    except RuntimeError:
        pass
    want = design_excitation(cfg, make_robot(cfg.robot, cfg.robot_options)).excitation
    assert seen == [want]
