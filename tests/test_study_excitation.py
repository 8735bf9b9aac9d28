"""A study's designed excitation (boundid.studies.excitation): the search of the shipped direct-drive
and H4 studies on a small budget, the criteria side by side, the [experiment] excitation keys as the
study file reads them, and the run on the designed trajectory (slow: H4 run, UR5 search)."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from boundid.errors import StudyError
from boundid.experiments.excitation import RampedMultisine
from boundid.experiments.excitation_design import CRITERIA
from boundid.experiments.limited_trajectories import limit_usage
from boundid.experiments.trajectories import condition_number, observation_matrix
from boundid.sets import Polytope
from boundid.studies.config import load_study, prior_box
from boundid.studies.data import tracking_config
from boundid.studies.excitation import (
    DESIGN_STREAM,
    PICKS,
    compare_criteria,
    design_excitation,
    design_rows,
    family,
)
from boundid.studies.registry import make_robot
from boundid.studies.runner import run_study
from tiny_study import run_study_text, tiny_study

STUDIES = Path(__file__).resolve().parents[1] / "studies"


def study_text(name: str, excitation: str | None = None, design: str | None = None, seed: int | None = None,
               edits: tuple[tuple[str, str], ...] = ()) -> str:
    """The shipped study ``name`` with [experiment] excitation set, its [experiment.design] table
    replaced by ``design`` (removed if None), its seed replaced and ``edits`` (old, new) applied."""
    text = (STUDIES / f"{name}.toml").read_text()
    text = re.sub(r"(?ms)^\[experiment\.design\]\n.*?(?=^\[)", "", text)
    text = re.sub(r"(?m)^excitation\s*=.*\n", "", text)
    if excitation is not None:
        assert text.count('source = "simulate"\n') == 1
        text = text.replace('source = "simulate"\n', f'source = "simulate"\nexcitation = "{excitation}"\n')
    if design is not None:
        assert text.count("\n[preprocessing]\n") == 1
        text = text.replace("\n[preprocessing]\n", f"\n[experiment.design]\n{design}\n\n[preprocessing]\n")
    if seed is not None:
        text, n = re.subn(r"(?m)^seed = \d+", f"seed = {seed}", text, count=1)
        assert n == 1
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new)
    return text


def write(folder: Path, name: str, text: str) -> Path:
    path = Path(folder) / f"{name}.toml"
    path.write_text(text)
    return path


# Short runs (the search scores the noise-free motion over duration_s) on seeds where the guaranteed
# criterion's pick among 3 candidates is not the first draw and cond(W) picks another one.
SHORT = {
    "direct_drive_rls": dict(seed=4, edits=(("duration_s = 10.0", "duration_s = 3.0"),)),
    "h4_obe": dict(seed=1, edits=(("duration_s = 20.0", "duration_s = 8.0"),
                                  ("validation_duration_s = 10.0", "validation_duration_s = 4.0"))),
}


@pytest.fixture(scope="module", params=sorted(SHORT))
def searched(request, tmp_path_factory):
    """(cfg, model, design, comparison) of a shortened shipped study, 3 candidates."""
    name = request.param
    path = write(tmp_path_factory.mktemp(name), name,
                 study_text(name, "guaranteed", "candidates = 3\nrate_hz = 10.0", **SHORT[name]))
    cfg = load_study(path)
    assert cfg.experiment.excitation == "guaranteed" and cfg.experiment.design.candidates == 3
    model = make_robot(cfg.robot, cfg.robot_options)
    design = design_excitation(cfg, model)
    return cfg, model, design, compare_criteria(cfg, model, design)


def test_the_search_keeps_the_guaranteed_criterions_best(searched):
    cfg, model, design, _ = searched
    s = design.search
    assert design.criterion == "guaranteed" and design.settings == cfg.experiment.design
    assert len(s.candidates) == 3 and s.failed == []
    g = s.scores["guaranteed"].to_numpy()
    assert design.chosen == int(np.argmin(g))
    assert np.all(g[design.chosen] < np.delete(g, design.chosen))  # strictly the best, no tie
    assert design.excitation is s.candidates[design.chosen]
    # the rows of the search: duration x rate_hz samples, every joint
    n_samples = int(np.ceil(cfg.experiment.duration_s * cfg.experiment.design.rate_hz - 1e-9))
    assert set(s.scores["rows"]) <= {n_samples * model.n_joints, (n_samples + 1) * model.n_joints}
    # the criteria really compete here (the seeds were chosen so): a wrong column would show
    assert design.chosen != 0 and s.best("cond") != design.chosen
    # the other criteria, asked by name, pick from the same candidates
    for crit in CRITERIA:
        assert design_excitation(cfg, model, crit).chosen == s.best(crit)


def test_the_chosen_score_is_the_exact_design_set_of_its_rows(searched):
    cfg, model, design, _ = searched
    fam = family(cfg, model)
    e_joint = np.broadcast_to(np.asarray(cfg.exact.e_max, dtype=float), (model.n_joints,))
    t, W, joint, e = design_rows(model, fam, design.excitation, cfg.experiment.design.rate_hz, e_joint)
    assert W.shape == (len(t) * model.n_joints, model.p)
    np.testing.assert_array_equal(joint, np.tile(np.arange(model.n_joints), len(t)))
    assert np.all(e == cfg.exact.e_max)
    # the rows are the inverse-dynamic regressor of the excitation's motion (sample-major)
    _, q, qd, qdd = fam.motion(design.excitation, cfg.experiment.design.rate_hz)
    np.testing.assert_allclose(W[: model.n_joints], model.regressor(q[:1], qd[:1], qdd[:1]).reshape(-1, model.p))
    _, half = prior_box(model, cfg.prior)
    b = Polytope(W, np.zeros(len(e)), e, box=(-half, half)).bounds()
    rel = (b.hi - b.lo) / (2 * half)
    np.testing.assert_allclose(design.search.widths[design.chosen], rel, atol=1e-7)
    np.testing.assert_allclose(design.search.scores.loc[design.chosen, "guaranteed"], rel.mean(), atol=1e-7)


def test_the_comparisons_exact_sets_lie_within_twice_the_design_sets(searched):
    cfg, model, design, cmp = searched
    assert [pk.label for pk in cmp.picks] == list(PICKS)
    assert [pk.candidate for pk in cmp.picks] == [0, *(design.search.best(c) for c in CRITERIA)]
    assert cmp.rate_hz == pytest.approx(1.0 / (cfg.experiment.sample_period_s * cfg.preprocessing.decimation))
    for pk in cmp.picks:
        assert pk.failures == {}, pk.failures
        assert pk.truth_inside, pk.label
        assert pk.design.shape == pk.exact.shape == (model.p,)
        assert np.all((pk.design >= 0) & (pk.design <= 1))
        assert np.all((pk.exact > 0) & (pk.exact <= 1 + 1e-9))
        # errors within (half) the bound: the exact interval is at most twice the design width
        assert np.all(pk.exact <= 2 * pk.design + 1e-7), (pk.label, pk.exact - 2 * pk.design)
        # the OBE's ellipsoid is an outer bound of the same polytope: never narrower than the exact bounds
        assert pk.obe is not None and np.all(pk.obe >= pk.exact - 1e-6), (pk.label, pk.obe - pk.exact)
        assert pk.wls is not None and np.all(np.isfinite(pk.wls))
        assert pk.rows % model.n_joints == 0 and pk.rows > design.search.scores.loc[pk.candidate, "rows"]
    # a candidate picked twice is recorded once: the same numbers under both labels
    by_label = {pk.label: pk for pk in cmp.picks}
    for a in PICKS:
        for b in PICKS:
            if by_label[a].candidate == by_label[b].candidate:
                np.testing.assert_array_equal(by_label[a].exact, by_label[b].exact)
    summary = cmp.summary()
    assert list(summary.index) == list(PICKS)
    np.testing.assert_allclose(summary["design width (search)"],
                               design.search.scores.loc[summary["candidate"], "guaranteed"])
    assert summary["truth in exact bounds"].all()


def test_the_search_is_seeded_and_starts_from_the_familys_first_draw(searched):
    cfg, model, design, _ = searched
    again = design_excitation(cfg, model)
    assert again.chosen == design.chosen
    cols = ["guaranteed", "cond", "logdet", "rows"]
    assert again.search.scores[cols].equals(design.search.scores[cols])
    first = family(cfg, model).draw(np.random.default_rng([cfg.seed, DESIGN_STREAM]))
    t = np.linspace(0.0, cfg.experiment.duration_s, 57)
    cand0 = design.search.candidates[0]
    if isinstance(first, RampedMultisine):
        assert first == cand0
        assert first != RampedMultisine.direct_drive_paper()  # a random member of the paper's family
        np.testing.assert_array_equal(first(t), cand0(t))
    else:
        for a, b in zip(first.evaluate(t), cand0.evaluate(t), strict=True):
            np.testing.assert_array_equal(a, b)
    # another seed, other candidates
    other = design_excitation(replace(cfg, seed=cfg.seed + 1), model)
    assert not other.search.scores[cols].equals(design.search.scores[cols])


def test_a_recording_has_no_family_and_default_designs_nothing(searched):
    cfg, model, _, _ = searched
    measured = replace(cfg, experiment=replace(cfg.experiment, source="measured"))
    with pytest.raises(StudyError, match="simulated experiment"):
        family(measured, model)
    with pytest.raises(StudyError, match="designs nothing"):
        design_excitation(cfg, model, "default")


def test_run_study_runs_the_open_loop_experiment_on_the_designed_torques(tmp_path):
    """The direct-drive run (2 s): StudyResult.design is the search, and the simulated torque law is
    its pick; without excitation the paper's torques (31)-(32) and no design."""
    tail = '\n[[estimators]]\nmethod = "wls"\nlabel = "WLS"\nregressions = ["filtered_dynamic"]\n' \
           '\n[exact]\nregression = "filtered_dynamic"\ne_max = 6.0\nlp_bounds = true\n'
    head = tiny_study("dd_design", 4, extra="\n[experiment.design]\ncandidates = 3\n")
    text = head.replace('source = "simulate"\n', 'source = "simulate"\nexcitation = "guaranteed"\n') + tail
    cfg, r = run_study_text(tmp_path, "dd_design", text)
    assert r.design is not None and "design" in r.timings
    assert r.design.chosen == int(np.argmin(r.design.search.scores["guaranteed"]))
    assert r.data.excitation is r.design.excitation
    # the recorded motion is the simulation of that torque law
    _, q, _, _ = family(cfg, r.model).motion(r.design.excitation, 1.0 / cfg.experiment.sample_period_s)
    counts = cfg.experiment.encoder_counts_per_rev
    assert np.max(np.abs(r.data.recording.q - q[: len(r.data.recording.q)])) <= 2 * np.pi / counts
    _, plain = run_study_text(tmp_path, "dd_plain", head + tail)
    assert plain.design is None and plain.data.excitation == RampedMultisine.direct_drive_paper()


# ---------------------------------------------------------------------------------------------
# the study file's keys
# ---------------------------------------------------------------------------------------------

def _no_rule_text(excitation: str | None, design: str | None) -> str:
    """The direct-drive study with [exact] e_max_rule instead of e_max (and no estimator bound)."""
    text = study_text("direct_drive_rls", excitation, design)
    text = re.sub(r"(?m)^e_max = 6\.0.*\n", "", text)
    return text.replace('[exact]\nregression = "filtered_dynamic"\n',
                        '[exact]\nregression = "filtered_dynamic"\ne_max_rule = { factor = 2.0, scaling = "one" }\n')


def test_the_design_keys_are_read(tmp_path):
    cfg = load_study(write(tmp_path, "direct_drive_rls", study_text(
        "direct_drive_rls", "logdet", "candidates = 5\nrate_hz = 25.0\ncompare = true")))
    assert cfg.experiment.excitation == "logdet"
    d = cfg.experiment.design
    assert (d.candidates, d.rate_hz, d.compare) == (5, 25.0, True)
    plain = load_study(write(tmp_path, "direct_drive_rls", study_text("direct_drive_rls")))
    assert plain.experiment.excitation == "default"
    assert (plain.experiment.design.candidates, plain.experiment.design.compare) == (12, False)


@pytest.mark.parametrize("excitation, design, match", [
    ("bogus", None, r"experiment\.excitation: must be one of"),
    ("Guaranteed", None, r"experiment\.excitation: must be one of"),
    ("guaranteed", "candidates = 0", r"experiment\.design\.candidates"),
    ("guaranteed", "candidates = 2.5", r"experiment\.design\.candidates"),
    ("guaranteed", "rate_hz = 0.0", r"experiment\.design\.rate_hz"),
    ("guaranteed", "rate_hz = -10.0", r"experiment\.design\.rate_hz"),
    ("guaranteed", "compare = 1", r"experiment\.design\.compare"),
    ("guaranteed", "candidates = 3\ncandidate = 3", r"experiment\.design\.candidate: unknown key"),
    ("default", "samples = 3", r"experiment\.design\.samples: unknown key"),
])
def test_bad_excitation_keys_are_refused(tmp_path, excitation, design, match):
    path = write(tmp_path, "direct_drive_rls", study_text("direct_drive_rls", excitation, design))
    with pytest.raises(StudyError, match=match) as err:
        load_study(path)
    assert str(path) in str(err.value)


def test_a_design_needs_a_numeric_exact_bound(tmp_path):
    # the same file with a bound rule is a valid study while it designs nothing
    cfg = load_study(write(tmp_path, "direct_drive_rls", _no_rule_text(None, None)))
    assert cfg.exact.e_max is None and cfg.exact.e_max_rule is not None
    for excitation, design in (("guaranteed", None), ("cond", None), (None, "compare = true")):
        path = write(tmp_path, "direct_drive_rls", _no_rule_text(excitation, design))
        with pytest.raises(StudyError, match=r"e_max_rule") as err:
            load_study(path)
        assert str(path) in str(err.value)


# ---------------------------------------------------------------------------------------------
# slow: a whole run on the designed trajectory, and the UR5's search
# ---------------------------------------------------------------------------------------------

@pytest.mark.slow  # ~10 s: the H4 study, 8 s + 4 s at 1 kHz, no SDP
def test_run_study_tracks_the_designed_h4_trajectory(tmp_path):
    edits = (*SHORT["h4_obe"]["edits"], ('sdp = ["outer", "inner", "john"]', "sdp = []"))
    text = study_text("h4_obe", "guaranteed", "candidates = 3", seed=SHORT["h4_obe"]["seed"], edits=edits)
    cfg = load_study(write(tmp_path, "h4_obe", text))
    r = run_study(cfg)
    d = r.design
    assert d is not None and d.criterion == "guaranteed" and "design" in r.timings
    assert d.chosen == int(np.argmin(d.search.scores["guaranteed"])) and d.chosen != 0
    # the identification run tracked the designed trajectory: the condition number it records is that
    # trajectory's (and no other candidate's)
    conds = [condition_number(observation_matrix(r.model, c), scaled=False) for c in d.search.candidates]
    assert r.data.info["identification_condition"] == pytest.approx(conds[d.chosen], rel=1e-12)
    assert all(abs(c / conds[d.chosen] - 1) > 1e-3 for k, c in enumerate(conds) if k != d.chosen)
    # ... and its encoder angles follow that reference closer than any other candidate's
    rec = r.data.recording
    err = [np.sqrt(np.mean((rec.q - c.evaluate(rec.t)[0]) ** 2)) for c in d.search.candidates]
    assert int(np.argmin(err)) == d.chosen and err[d.chosen] < 0.5 * min(np.delete(err, d.chosen))
    # the validation run is another trajectory
    assert r.data.info["validation_condition"] != pytest.approx(conds[d.chosen], rel=1e-6)
    assert r.exact is not None


@pytest.mark.slow  # ~10 s: the UR5 model (52 base parameters) and two candidates
def test_the_ur5_design_stays_within_the_joint_limits(tmp_path):
    cfg = load_study(write(tmp_path, "ur5_urdf", study_text("ur5_urdf", "guaranteed", "candidates = 2")))
    model = make_robot(cfg.robot, cfg.robot_options)
    d = design_excitation(cfg, model)
    assert len(d.search.candidates) == 2
    assert d.chosen == int(np.argmin(d.search.scores["guaranteed"]))
    traj = d.excitation
    assert traj.duration >= cfg.experiment.duration_s - 1e-9
    t = np.arange(0.0, cfg.experiment.duration_s, 1e-3)
    margin = tracking_config(cfg).margin
    for m in (margin, 0.0):  # within the limits shrunk by the experiment's margin, a fortiori the file's
        use = limit_usage(model, *traj.evaluate(t), margin=m)
        assert use["position"] <= 1e-12, use
        assert max(use["velocity"], use["acceleration"], use["effort"]) <= 1.0 + 1e-9, use
    # scaled up to a limit, not a timid trajectory
    use = limit_usage(model, *traj.evaluate(t), margin=margin)
    assert max(use["velocity"], use["acceleration"], use["effort"]) > 0.99
    assert d.search.scores["rows"].iloc[0] == round(cfg.experiment.duration_s * cfg.experiment.design.rate_hz) \
        * model.n_joints
