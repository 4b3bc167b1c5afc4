"""The rules of the core's public arguments, each declared once and checked at the boundary.

In the spirit of scikit-learn's ``_param_validation``: a rule is a small
declared constraint (:class:`Interval` for numbers, :class:`Options` for
words) that knows how to say what it wants. A public function checks each
argument once, where it comes in, and passes the checked value on; nested
calls trust it. The rules:

=================  ==========================================================
``mass``           :data:`MASS`: a finite positive number of kg (``None``
                   where the method estimates it): :func:`check_mass`; a
                   structure's is a symmetric positive-definite matrix
                   (:func:`nlid.model.structure.structure_mass`), and
                   :func:`parse_mass` reads either written as text (a
                   number, ``"estimate"``, a matrix literal, ``diag(...)``
                   or a CSV/JSON/.npy file).
``cutoff``         a positive number of Hz below the Nyquist frequency of
                   the record (:func:`check_cutoff`; without ``fs``, just
                   positive).
``seed``           :data:`SEED`: an integer from 0 to 2**63 - 1
                   (:func:`check_seed`).
``fs``             :data:`FS`: a positive number of Hz, at most
                   :data:`MAX_FS`.
``duration``       :data:`DURATION`: a positive number of seconds; with
                   ``fs``, from :data:`MIN_SAMPLES` to :data:`MAX_SAMPLES`
                   samples (:func:`check_samples`).
``noise``          simulated measurement noise, a fraction of each response
                   channel's standard deviation (:data:`NOISE_FRACTION`,
                   :func:`check_noise`), or the posterior's known noise
                   standard deviation in SI units (:func:`check_noise_sd`).
=================  ==========================================================

Choices of the rules, where a rule had to be chosen:

* **Seeds** are integers (``bool`` and ``1.5`` are refused, not truncated)
  from 0 to ``2**63 - 1``. :class:`numpy.random.SeedSequence` takes any
  non-negative integer, but seeds are written into record metadata, run
  specs and study files, and a TOML integer is a signed 64-bit number: a
  larger seed could not be written back.
* **Noise levels** are finite and either exactly 0 (a noise-free channel) or
  at least :data:`MIN_NOISE` (1e-12) of the channel's standard deviation: a
  smaller level is lost in the rounding of the signal (double precision
  resolves about 1e-16 of it), so it cannot mean what it says and is taken
  for a typo or a unit mistake. A simulated level is that fraction
  directly; a known standard deviation given to the posterior is compared
  with the record's channel when the record is at hand
  (:func:`check_noise_sd` with ``scales``). The upper bound of a simulated
  fraction is :data:`MAX_NOISE_FRACTION` (10: ten times the signal).
* **Cut-offs** lie strictly between 0 and the Nyquist frequency ``fs / 2``.

Messages are one line and name the Python parameter (``mass=``); the
command line maps such names to its flags. Each rule raises the error type
its callers raised before (:class:`~nlid.errors.InputError` unless a caller
passes another). :func:`did_you_mean` is the one suggestion helper of nlid.
"""

from __future__ import annotations

import ast
import io
import json
import math
import numbers
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from difflib import get_close_matches
from typing import Any

from ..errors import InputError, brief, one_line

__all__ = [
    "Interval",
    "Options",
    "MASS",
    "ESTIMATE",
    "parse_mass",
    "CUTOFF",
    "SEED",
    "FS",
    "DURATION",
    "NOISE_FRACTION",
    "NOISE_SD",
    "HOLDOUT_FRACTION",
    "MAX_FS",
    "MAX_SAMPLES",
    "MIN_SAMPLES",
    "MAX_SEED",
    "MIN_NOISE",
    "MAX_NOISE_FRACTION",
    "NOISE_SD_CHANNELS",
    "NOISE_UNITS",
    "check_mass",
    "check_cutoff",
    "check_seed",
    "check_samples",
    "check_noise",
    "check_noise_sd",
    "did_you_mean",
]

#: Highest sampling frequency of a simulation (Hz).
MAX_FS = 1e7
#: Most samples a simulation may have (checked before anything is allocated).
MAX_SAMPLES = 20_000_000
#: Fewest samples a simulation may have.
MIN_SAMPLES = 64
#: Largest seed: the largest integer a TOML file (a signed 64-bit integer) can hold.
MAX_SEED = 2**63 - 1
#: Smallest non-zero noise level, relative to the channel's standard deviation.
MIN_NOISE = 1e-12
#: Largest simulated noise level, as a fraction of the channel's standard deviation.
MAX_NOISE_FRACTION = 10.0
#: Channels whose known noise standard deviation the posterior takes, and their units.
NOISE_UNITS = {"z": "m", "v": "m/s"}
NOISE_SD_CHANNELS = tuple(NOISE_UNITS)


def _shown(value: Any) -> str:
    """A value as a message shows it: integers exactly, other numbers with ``:g``, the rest as ``repr``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return brief(value)
    if isinstance(value, numbers.Integral):
        return str(int(value))
    return f"{float(value):g}"


# --------------------------------------------------------------------------- the two kinds of rule
@dataclass(frozen=True)
class Interval:
    """Real numbers (or integers) between two bounds, and the words that describe them.

    Parameters
    ----------
    low, high
        Bounds; ``None`` for none. Values must be finite in any case.
    closed
        Which bounds belong to the interval: ``"both"``, ``"left"``,
        ``"right"`` or ``"neither"``.
    words
        What the message says a value must be (``"a positive number of kg"``).
    integer
        Only integers (``numbers.Integral``, not ``bool``) are accepted.
    zero
        0 is accepted too, outside the interval (a noise-free channel).
    """

    low: float | None
    high: float | None
    closed: str
    words: str
    integer: bool = False
    zero: bool = False

    def __post_init__(self) -> None:
        if self.closed not in ("both", "left", "right", "neither"):
            raise ValueError(f"closed must be 'both', 'left', 'right' or 'neither', got {self.closed!r}")

    def accepts(self, value: Any) -> bool:
        """True if ``value`` satisfies the rule."""
        kind = numbers.Integral if self.integer else numbers.Real
        if isinstance(value, bool) or not isinstance(value, kind):
            return False
        if not self.integer and not math.isfinite(float(value)):
            return False
        if self.zero and value == 0:
            return True
        left = self.closed in ("both", "left")
        right = self.closed in ("both", "right")
        if self.low is not None and not (value >= self.low if left else value > self.low):
            return False
        return self.high is None or (value <= self.high if right else value < self.high)

    def reason(self, value: Any) -> str | None:
        """``None`` if ``value`` satisfies the rule, else ``"must be <words>, got <value>"``."""
        return None if self.accepts(value) else f"must be {self.words}, got {_shown(value)}"

    def check(self, value: Any, name: str, error: type[InputError] = InputError) -> Any:
        """``value`` as an ``int`` or a ``float`` if it satisfies the rule, else ``error("<name> must be ...")``."""
        why = self.reason(value)
        if why is not None:
            raise error(f"{name} {why}")
        return int(value) if self.integer else float(value)


@dataclass(frozen=True)
class Options:
    """One of a few words (scikit-learn's ``StrOptions``)."""

    options: tuple[str, ...]

    def reason(self, value: Any) -> str | None:
        """``None`` if ``value`` is one of the options, else ``"must be one of ..., got ..."``."""
        if isinstance(value, str) and value in self.options:
            return None
        hint = did_you_mean(value, self.options) if isinstance(value, str) else ""
        return f"must be one of {', '.join(self.options)}, got {brief(value)}{hint}"

    def check(self, value: Any, name: str, error: type[InputError] = InputError) -> str:
        """``value`` if it is one of the options, else ``error("<name> must be one of ...")``."""
        why = self.reason(value)
        if why is not None:
            raise error(f"{name} {why}")
        return value


# --------------------------------------------------------------------------- the declared rules
#: A known mass.
MASS = Interval(0.0, None, "neither", "a positive number of kg")
#: The fraction of a record held out (its last part).
HOLDOUT_FRACTION = Interval(0.0, 1.0, "neither", "a fraction between 0 and 1 (0.25: the last quarter)")
#: A random seed.
SEED = Interval(0, MAX_SEED, "both", "an integer from 0 to 2**63 - 1", integer=True)
#: A filter frequency when no record says what its Nyquist frequency is (:func:`check_cutoff`).
CUTOFF = Interval(0.0, None, "neither", "a positive number of Hz")
#: A sampling frequency of a simulation.
FS = Interval(0.0, MAX_FS, "right", f"a positive number of Hz, at most {MAX_FS:g}")
#: A record length.
DURATION = Interval(0.0, None, "neither", "a positive number of seconds")
#: A simulated noise level, as a fraction of the channel's standard deviation.
NOISE_FRACTION = Interval(
    MIN_NOISE,
    MAX_NOISE_FRACTION,
    "left",
    f"0 or a fraction from {MIN_NOISE:g} to below {MAX_NOISE_FRACTION:g} (0.02 = 2 %)",
    zero=True,
)

#: A known noise standard deviation of the posterior, per channel (SI units).
NOISE_SD = {c: Interval(0.0, None, "both", f"a non-negative number ({unit})") for c, unit in NOISE_UNITS.items()}


# --------------------------------------------------------------------------- the checks
def check_mass(mass: Any, *, name: str = "mass=", error: type[InputError] = InputError) -> float | None:
    """``mass`` as a float (kg), ``None`` passed through (the method estimates it).

    Raises
    ------
    InputError
        ``"mass= must be a positive number of kg, got -1"`` for anything but a finite positive number.
    """
    return None if mass is None else MASS.check(mass, name, error)


#: The mass setting that asks the method to estimate the mass (a structure's ``mass=None`` takes the record's).
ESTIMATE = "estimate"
#: Files a mass matrix is read from (``np.load`` without pickles for ``.npy``).
MASS_FILES = (".csv", ".txt", ".json", ".npy")
_MATRIX_TEXT = re.compile(r"^[\s\[\]\(\),0-9eE+.\-]+$")


def parse_mass(text: str | os.PathLike[str], *, name: str = "mass=") -> Any:
    """A mass written as text: a number of kg, ``"estimate"``, or a matrix (as a list of rows, kg).

    Accepted: ``"0.2"``; ``"estimate"``; a literal ``"[[1,0,0],[0,1,0],[0,0,2]]"`` (a flat list is the
    diagonal); ``"diag(1,1,2)"``; a file ``.csv``/``.txt`` (rows of numbers), ``.json`` (a matrix, a list,
    or an object with ``"mass"``, as a sidecar) or ``.npy`` (read without pickles). Nothing is evaluated:
    a literal is read by :func:`json.loads` or, for a Python spelling such as ``1.``, by
    :func:`ast.literal_eval` after checking it holds only numbers, brackets and commas. The shape and the
    physics (symmetric, positive definite, one row per DOF) are checked by whoever knows the record
    (:func:`check_mass`, :func:`nlid.model.structure.structure_mass`).

    Raises
    ------
    InputError
        One line naming ``name``: an unreadable literal or file.
    """
    raw = os.fspath(text).strip()
    if raw.lower() == ESTIMATE:
        return ESTIMATE
    try:
        return float(raw)
    except ValueError:
        pass
    diag = re.fullmatch(r"diag\s*\((.*)\)", raw, flags=re.IGNORECASE)
    if diag:
        try:
            values = [float(x) for x in diag.group(1).split(",") if x.strip()]
        except ValueError:
            values = []
        if not values:
            return _bad_mass(raw, name)
        return [[x if i == j else 0.0 for j in range(len(values))] for i, x in enumerate(values)]
    if raw.startswith("[") and _MATRIX_TEXT.match(raw):
        try:
            return json.loads(raw)
        except ValueError:
            try:
                return ast.literal_eval(raw)
            except (ValueError, SyntaxError):
                return _bad_mass(raw, name)
    if raw.lower().endswith(MASS_FILES) or os.path.isfile(raw):
        return _mass_file(raw, name)
    return _bad_mass(raw, name)


def _bad_mass(raw: str, name: str) -> Any:
    raise InputError(
        f"{name} must be a number of kg, 'estimate', a matrix such as '[[1,0],[0,2]]' or 'diag(1,2)', or a file "
        f"({', '.join(MASS_FILES)}), got {brief(raw)}"
    )


def _mass_file(path: str, name: str) -> Any:
    import numpy as np

    if not os.path.isfile(path):
        raise InputError(f"{name} names a file that does not exist: {brief(path)}")
    suffix = os.path.splitext(path)[1].lower()
    try:
        if suffix == ".npy":
            return np.load(path, allow_pickle=False).tolist()
        if suffix == ".json":
            with open(path, encoding="utf-8") as handle:
                data = json.load(handle)
            return data.get("mass") if isinstance(data, dict) else data
        with open(path, encoding="utf-8") as handle:
            body = handle.read()
        return np.loadtxt(io.StringIO(body), delimiter="," if "," in body else None, ndmin=1).tolist()
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise InputError(f"{name} file {brief(path)} is not a matrix of numbers: {one_line(str(exc), 120)}") from None


def check_cutoff(cutoff: Any, fs: float | None = None, *, name: str = "cutoff=") -> float | None:
    """A filter frequency (Hz) as a float, ``None`` passed through (the filter chooses).

    Parameters
    ----------
    cutoff
        The frequency.
    fs
        Sampling frequency of the record (Hz): the frequency must lie below
        its Nyquist frequency ``fs / 2``. ``None`` when no record is at hand
        yet (only positivity is checked then; the record checks the rest).
    name
        How the message names it (``"cutoff="``, ``"crossover"``...).

    Raises
    ------
    InputError
        ``"cutoff= must be a positive number of Hz below the Nyquist frequency 1024 Hz, got 5000"``.
    """
    if cutoff is None:
        return None
    if fs is None:
        rule = CUTOFF
    else:
        nyquist = float(fs) / 2.0
        rule = Interval(0.0, nyquist, "neither", f"a positive number of Hz below the Nyquist frequency {nyquist:g} Hz")
    return rule.check(cutoff, name)


def check_seed(seed: Any, name: str = "seed") -> int:
    """``seed`` as an int if it is a valid random seed (an integer from 0 to 2**63 - 1; see the module docstring).

    Raises
    ------
    InputError
        ``"seed must be an integer from 0 to 2**63 - 1, got 1.5"``.
    """
    return SEED.check(seed, name)


def check_samples(duration: float, fs: float, *, where: str = "") -> int:
    """The number of samples of a record ``duration`` seconds long at ``fs`` Hz, within the limits.

    ``duration`` and ``fs`` must already satisfy :data:`DURATION` and :data:`FS`; ``where`` starts the
    message (``"preset 'x': "``).

    Raises
    ------
    InputError
        Fewer than :data:`MIN_SAMPLES` or more than :data:`MAX_SAMPLES`.
    """
    n = duration * fs
    if n > MAX_SAMPLES:
        raise InputError(
            f"{where}duration x fs = {n:.3g} samples, more than the limit of {MAX_SAMPLES:.3g} "
            f"({8 * 4 * MAX_SAMPLES / 1e9:.1f} GB of channels); shorten the duration or lower fs"
        )
    if n < MIN_SAMPLES:
        raise InputError(f"{where}duration x fs = {n:.3g} samples; at least {MIN_SAMPLES} are needed")
    return int(round(n))


def check_noise(noise: Any, channels: Sequence[str], *, name: str = "noise") -> dict[str, float]:
    """Simulated noise levels: one fraction for every channel, or a mapping channel -> fraction.

    Parameters
    ----------
    noise
        A number, or a mapping such as ``{"z": 0.02}`` (unlisted channels: 0).
    channels
        The response channels recorded; a mapping may name only these.
    name
        How the message names the argument.

    Returns
    -------
    dict
        ``{channel: fraction}`` for every channel of ``channels``, in that order.

    Raises
    ------
    InputError
        A channel not recorded, or a level that is not :data:`NOISE_FRACTION`.
    """
    if isinstance(noise, Mapping):
        for channel in noise:
            if channel not in channels:
                raise InputError(
                    f"{name} is given for channel {channel!r}, which is not recorded "
                    f"(the channels are {', '.join(channels)})"
                )
        levels = {c: noise.get(c, 0.0) for c in channels}
        return {c: NOISE_FRACTION.check(x, f"{name} on {c}") for c, x in levels.items()}
    level = NOISE_FRACTION.check(noise, name)
    return {c: level for c in channels}


def check_noise_sd(noise: Any, *, scales: Mapping[str, float] | None = None) -> dict[str, float]:
    """Known noise standard deviations of the posterior, ``{"z": 4e-4, "v": 0.014}`` (m, m/s).

    Parameters
    ----------
    noise
        The mapping, or ``None`` (nothing known: ``{}``).
    scales
        Standard deviation of each channel of the record, when it is at
        hand: a non-zero level must then be at least :data:`MIN_NOISE` of it
        (see the module docstring).

    Raises
    ------
    InputError
        Not a mapping, a channel other than z and v, a level that is not a
        non-negative number, or a level too small to mean anything.
    """
    if noise is None:
        return {}
    if not isinstance(noise, Mapping):
        raise InputError(f"noise must map channels to standard deviations, e.g. {{'z': 4e-4}}; got {brief(noise)}")
    for channel in noise:
        if channel not in NOISE_SD_CHANNELS:
            raise InputError(
                f"noise is given for channel {channel!r}; only z and v are corrected "
                "(noise on the acceleration needs no level: it does not bias the estimate)"
            )
    out = {c: NOISE_SD[c].check(sd, f"noise on {c}") for c, sd in noise.items()}
    for c, sd in out.items():
        scale = (scales or {}).get(c)
        if scale is not None and 0 < sd < MIN_NOISE * scale:
            unit = NOISE_UNITS[c]
            raise InputError(
                f"noise on {c} is {sd:g} {unit}, less than {MIN_NOISE:g} of the channel's standard deviation "
                f"({scale:.3g} {unit}): give 0 for a noise-free channel, or the sensor's noise level"
            )
    return out


def did_you_mean(value: Any, choices: Iterable[Any]) -> str:
    """``" (did you mean 'x'?)"`` for the choice closest to ``value``, or ``""`` when none is close.

    Examples
    --------
    >>> did_you_mean("rsf", ["rfs", "sindy"])
    " (did you mean 'rfs'?)"
    """
    hint = get_close_matches(str(value), [str(c) for c in choices], n=1)
    return f" (did you mean {hint[0]!r}?)" if hint else ""
