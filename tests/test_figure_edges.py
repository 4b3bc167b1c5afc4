"""Figures a newcomer misread (issue 35, item 5): no elastic force without a spring; legends off the data."""

from __future__ import annotations

import numpy as np
import pytest

import nlid
from nlid.report.plotting import new_figure


@pytest.fixture(scope="module")
def friction_fit(short_record):
    """A model without a spring (as EMPS's): v, sign(v) and the constant 1."""
    return nlid.identify(short_record, "v, sign(v)", "rfs", mass=0.2, without="z")


def test_no_spring_no_elastic_force(friction_fit):
    assert "z" not in friction_fit.terms and "1" in friction_fit.terms
    for potential in (False, True):
        ax = friction_fit.plot_stiffness(potential=potential)
        assert not ax.lines  # nothing drawn as K(z) or U(z)
        note = [t for t in ax.texts if t.get_gid() == "no-spring"]
        assert note and "no spring" in note[0].get_text() and "constant term 1" in note[0].get_text()
        assert "elastic force" not in ax.get_title().replace("no elastic force", "")


def test_a_spring_is_still_drawn(short_record):
    fit = nlid.identify(short_record, "z^3, z^2, v*|v|", "rfs", mass=0.2)
    _, ax = new_figure()
    fit.plot_stiffness(ax=ax)
    assert ax.lines and ax.get_title().endswith("elastic force")
    np.testing.assert_allclose(ax.lines[0].get_ydata(), fit.elastic(ax.lines[0].get_xdata()))
