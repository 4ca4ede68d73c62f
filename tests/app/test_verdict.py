"""The Identify page's verdict says no more than the record supports (no browser needed)."""

import numpy as np
import pytest

pytest.importorskip("panel")

from lubeviz.app.identify_page import verdict_text  # noqa: E402
from lubeviz.app.text import BADGE_COLOURS, badge  # noqa: E402
from lubeviz.identify.fit.result import Identification  # noqa: E402
from lubeviz.units import MLMIN_PER_M3S

QT = 546 / MLMIN_PER_M3S


def result(q_mlmin, intervals_mlmin, p_value=0.5):
    iv = tuple(None if i is None else (i[0] / MLMIN_PER_M3S, None if i[1] is None else i[1] / MLMIN_PER_M3S) for i in intervals_mlmin)
    return Identification(q=np.array(q_mlmin) / MLMIN_PER_M3S, q_std=None, converged=True, iterations=1, starts_tried=1,
                          paths=(), features_names=(), features_measured=np.zeros(0), features_model=np.zeros(0),
                          residual=np.zeros(0), total_error=0.0, mode="best", evaluations=1, seconds=0.0,
                          message="", q_threshold=np.array([QT, QT]), chi2=1.0, dof=4, p_value=p_value,
                          intervals=iv, level=0.01)


def test_a_verdict_holds_over_the_whole_interval_or_says_it_spans_q_t():
    r = result([420, 540], [(410, 430), (500, 600)])
    assert verdict_text(r, 0) == badge("starved")
    # 540 ml/min is 'normal', but the interval 500-600 reaches from starved to over-supplied
    assert verdict_text(r, 1).startswith(badge("starved") + " to " + badge("over-supplied"))
    assert "spans" in verdict_text(r, 1)


def test_an_open_upper_end_counts_as_over_supplied():
    r = result([700, 700], [(650, None), (500, None)])
    assert verdict_text(r, 0) == badge("over-supplied")
    assert verdict_text(r, 1).startswith(badge("starved") + " to " + badge("over-supplied"))


def test_a_record_the_model_does_not_explain_gets_an_uncertain_verdict():
    r = result([420, 420], [(410, 430), (410, 430)], p_value=1e-6)
    assert "uncertain" in verdict_text(r, 0) and verdict_text(r, 0).startswith(badge("starved"))


@pytest.mark.parametrize("verdict", sorted(BADGE_COLOURS))
def test_a_verdict_badge_writes_its_word_in_a_colour_and_no_emoji(verdict):
    # emoji circles showed as empty boxes on a machine without an emoji font (issue 38)
    shown = badge(verdict)
    assert f">{verdict}</span>" in shown and BADGE_COLOURS[verdict][0] in shown
    assert all(ord(c) < 0x2000 for c in shown)
    assert len({BADGE_COLOURS[v][0] for v in BADGE_COLOURS}) == 3  # three colours for three verdicts


def test_anything_else_is_shown_as_plain_text():
    shown = badge("<b>x</b>")
    assert "<b>" not in shown and "x" in shown
