"""The acceptance rule: effective sample size, information criterion, ranking."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from nlid.discovery import AcceptanceRule, Evidence, Scores
from nlid.discovery.evidence import delta_bic, effective_sample_size, integrated_time, judge, rank
from nlid.errors import InputError


def test_integrated_time_of_white_and_correlated_noise():
    rng = np.random.default_rng(0)
    white = rng.standard_normal(100_000)
    assert integrated_time(white) == pytest.approx(1.0, abs=0.1)
    phi = 0.9  # AR(1): tau = (1 + phi) / (1 - phi) = 19
    ar = signal.lfilter([1.0], [1.0, -phi], white)
    assert integrated_time(ar) == pytest.approx(19.0, rel=0.15)
    n_eff, tau = effective_sample_size(ar)
    assert n_eff == pytest.approx(ar.size / tau)


def test_delta_bic_penalises_parameters_with_the_effective_sample_size():
    assert delta_bic(1.0, 1, 1000.0) == pytest.approx(math.log(1000.0))
    # the same 1 % drop of the RSS is decisive with N = 1e6 but not with N_eff = 500
    assert delta_bic(0.99, 1, 1e6) < -10 < delta_bic(0.99, 1, 500.0)


def _scores(fr: float, fr_ho: float) -> Scores:
    return Scores(eps=fr, force_residual=fr, eps_holdout=fr_ho, force_residual_holdout=fr_ho)


def test_judge_and_rank_pick_the_best_eligible_candidate():
    rule = AcceptanceRule()
    before = _scores(10.0, 10.0)
    strong = judge(Evidence("a", ["x"], extra_parameters=1), before, _scores(5.0, 5.0), 1000.0, 3.0, rule)
    weaker = judge(Evidence("b", ["y"], extra_parameters=1), before, _scores(6.0, 6.0), 1000.0, 3.0, rule)
    overfit = judge(Evidence("c", ["w"], extra_parameters=1), before, _scores(5.0, 9.8), 1000.0, 3.0, rule)
    failed = Evidence("d", status="failed", reason="rank deficient")
    assert strong.explained_holdout == pytest.approx(0.75) and strong.status == "eligible"
    assert overfit.status == "rejected" and "held-out" in overfit.reason
    ranking, accepted = rank([failed, overfit, weaker, strong])
    assert accepted is strong and strong.status == "accepted"
    assert [e.effect for e in ranking] == ["a", "b", "c", "d"]
    assert weaker.status == "rejected" and "'a' explains more" in weaker.reason


def test_small_improvements_with_few_effective_samples_are_not_accepted():
    rule = AcceptanceRule()
    before = _scores(10.0, 10.0)
    ev = judge(Evidence("a", ["x"], extra_parameters=2), before, _scores(9.0, 9.0), 40.0, 500.0, rule)
    assert ev.explained_holdout > rule.min_explained and ev.delta_bic > rule.max_delta_bic
    assert ev.status == "rejected" and "dBIC" in ev.reason
    assert rank([ev])[1] is None


def test_the_rule_is_validated_and_stated():
    with pytest.raises(InputError):
        AcceptanceRule(min_explained=0.0)
    with pytest.raises(InputError):
        AcceptanceRule(max_delta_bic=float("nan"))
    text = AcceptanceRule().describe()
    assert "held-out" in text and "effective sample size" in text and "5.1 %" in text
