"""The settings of oe's segments and stages, shared by one DOF (:mod:`nlid_oe.identifier`) and structures
(:mod:`nlid_oe.structure`)."""

from __future__ import annotations

#: Segment length as a fraction of the predictability horizon (over a third of the horizon an initial
#: error grows by about (SENSITIVITY_LIMIT / SENSITIVITY_DELTA)^(1/3) = 10).
SEGMENT_FRACTION = 1.0 / 3.0
#: Fewest samples in a segment.
MIN_SEGMENT = 32
#: Fewest samples in a record.
MIN_SAMPLES = 64
#: A start model whose free run misses the data by more than this fraction of std(z) (RMS) is first fitted
#: on short segments (:data:`SHORT_PERIODS` periods of the start model's highest natural frequency).
DIRECT_LIMIT = 0.02
#: Most segments of the short-segment stage (longer segments on long records keep its Jacobian dense).
MAX_SHORT_SEGMENTS = 40
#: Largest Jacobian (rows x columns) built dense.
DENSE_LIMIT = 16_000_000
#: Largest reduced problem (rows x columns^2 of :meth:`Problem.reduced`, the SVD's cost) whose trust-region
#: steps are exact (an SVD per Jacobian: about a second on one core at the limit); beyond it, LSMR on the
#: sparse reduced Jacobian (hundreds of segments: the SVD of a 8000 x 1200 matrix took 30 s).
EXACT_LIMIT = 2e9
#: Length of the short segments, in periods of the start model's highest natural frequency.
SHORT_PERIODS = 5.0
#: Quantile of the predictability times (from :data:`nlid.scoring.HORIZON_STARTS` starts) taken as the
#: horizon: a record is fitted in one free run only when three quarters of its starts stay predictable
#: (the chaos check of the scores uses the median; a single free run over a record that is sensitive in a
#: quarter of its starts has local minima far from the truth).
HORIZON_QUANTILE = 0.25
#: The whole-record free run fitted after the short segments is kept only when its RMS error on the data is
#: at most this multiple of the short segments' (a larger one is a local minimum of the single free run:
#: the short segments' answer is kept).
WHOLE_RECORD_RATIO = 1.5
#: Automatic multiple shooting whose RMS error exceeds this multiple of the measurement noise floor
#: (:func:`nlid.signal.derivatives.noise_sd`, relative to each channel's std) halves its segments and fits again,
#: at most :data:`MAX_HALVINGS` times.
NOISE_RATIO = 1.25
MAX_HALVINGS = 3
