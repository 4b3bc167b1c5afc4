"""What an identified model predicts: nonlinear frequency responses by harmonic balance and continuation.

::

    import nlid
    from nlid.response import frequency_response

    fit = nlid.identify(record, "z^3, z^2, v*|v|", mass=0.2)
    resp = fit.frequency_response(force=[0.5, 1, 2], band=(5, 30))   # = frequency_response(fit, ...)
    resp.to_frame()                   # one row per point and DOF
    resp.plot()                       # stable/unstable branches, folds and jumps, backbones
    checked = resp.verify(sweep_rate=0.02)   # stable points and jumps against time integration
    scored = resp.compare(nlid.load("stepped.csv"))   # measured stepped-sine points: the prediction error

One job per module: the basis and quadratures (``harmonics``), the equations
(``system``), the AFT of the terms with exact Jacobians (``aft``, memory
states in ``memory``), the balance and Hill's stability (``balance``),
pseudo-arclength continuation (``continuation``), the curves and what
continues them (``curves``, ``solve``), backbones (``backbone``), time
integration checks (``timesim``, ``verify``), posterior bands (``bands``),
measured stepped and swept sines (``measured``, ``sine``), the result
(``result``) and its figure (``plots``).
"""

from .api import backbone, force_response, frequency_response
from .backbone import Backbone
from .bands import ResponseBand
from .curves import ResponseCurve, SpecialPoint
from .measured import MeasuredResponse, measure
from .result import FrequencyResponse
from .solve import Settings
from .verify import PointCheck, SweepCheck

__all__ = [
    "frequency_response",
    "force_response",
    "backbone",
    "measure",
    "FrequencyResponse",
    "ResponseCurve",
    "SpecialPoint",
    "Backbone",
    "Settings",
    "PointCheck",
    "SweepCheck",
    "ResponseBand",
    "MeasuredResponse",
]
