"""Simulation presets: the paper's numerical example and an analogue of its rig.

``paper-numerical`` (paper Sec. 3, Eq. 21, parameters from NOTES.md)
    ``m z'' + c_v z' + mu z'|z'| + k3 z^3 + k2 z^2 - k1 z + m g = f`` with
    m = 0.2 kg, k3 = 1e6 N/m^3, k2 = 5e3 N/m^2, k1 = 500 N/m (the ``z``
    coefficient is -500), c_v = 1 N s/m, mu = 5 N s^2/m^2, g = 9.81 m/s^2.
    Eq. 21 prints the friction as ``mu sign(z') z^2``; its unit says it is
    quadratic damping ``mu z'|z'|`` (NOTES.md). White Gaussian force of RMS
    50 N held over each sample, 2048 Hz, 60 s (122 880 samples).

``paper-experimental`` (paper Sec. 4, Eq. 23-24, Table 5)
    The rig's identified model used as truth: k3 = 7.57e5 N/m^3,
    k2 = 986 N/m^2, linear term -565 N/m, c_v = 4.26 N s/m, and the
    position-dependent friction of Eq. 24 with c0 = 1.51 N, c1 = -1.32 N s/m,
    c2 = -5.86 N s^2/m^2, c3 = 1.84 N s^3/m^3 multiplying ``|px(z)|`` whose
    roots are those of the true stiffness (z- = -0.02798 m, z+ = 0.02668 m);
    m = 0.265 kg so m g = 2.60 N. Its stable equilibria are -0.0300 m and
    +0.0239 m, as measured on the rig (Table 7). Base excitation
    ``f = -m b''`` with ``b''`` Gaussian, low-passed at 100 Hz (zero-phase
    Butterworth, order 4, the band of a typical shaker test), scaled to
    f_rms = 10 N (b''_rms = 37.7 m/s^2 = 3.8 g): the motion then crosses
    between the wells about 3 times per second and spends about 80 % of the
    time in the deeper, negative well, like the rig's record (Fig. 17).
    512 Hz, 120 s (61 440 samples).

Randomness: ``numpy.random.SeedSequence(seed).spawn(4)`` gives independent
streams for the force and for the noise on z, v and a, so the force of a given
seed does not depend on which channels are written or how noisy they are.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

from ..base.validate import DURATION, FS, MASS, check_noise, check_samples, check_seed, did_you_mean
from ..errors import InputError, TermError, brief
from .structure_presets import (
    STRUCTURE_PRESETS,
    StructurePreset,
    _check_band,
    _check_coefficients,
    _finite,
    override_fields,
)

if TYPE_CHECKING:  # imported where used: the preset table is read by 'nlid simulate --help'
    import numpy as np

    from ..data.record import Record
    from ..model.terms import Model

__all__ = ["Preset", "PRESETS", "get_preset", "RESPONSE_CHANNELS"]

#: Channels that can carry measurement noise.
RESPONSE_CHANNELS = ("z", "v", "a")
#: The keys of a preset's ``multisine`` table (:mod:`nlid.simulation.multisine`).
MULTISINE_KEYS = ("period", "lines", "periods", "transient_periods", "phases", "oversample")


@dataclass(frozen=True)
class Preset:
    """A simulated test: model, truth, excitation and sampling.

    Attributes
    ----------
    name, description
        Identification and one-line summary.
    terms
        The model's terms (comma-separated; ``1``, ``z``, ``v`` are added).
    coefficients
        True coefficient of every term in ``R`` (the ``1`` term is ``m g``).
    mass, g
        Mass (kg) and gravitational acceleration (m/s^2).
    fs, duration
        Sampling frequency (Hz) and length (s).
    force_rms
        RMS of the external force (N).
    band
        ``(low, high)`` band of the force in Hz, ``None`` for white.
    excitation
        ``"force"`` or ``"base"`` (``f = -m b''``; only changes the metadata).
    x0
        Initial displacement and velocity.
    reference
        Where the preset comes from.
    sine
        A stepped- or swept-sine test instead of the random force: the fields of
        :class:`nlid.simulation.SineTest` (``kind``, ``amplitude``, ``band``...); the record's length
        is then the test's, and ``meta["signal"]`` describes it (the steps' frequencies and samples).
    multisine
        A periodic multisine of RMS ``force_rms`` instead of the random force (:mod:`nlid.simulation.multisine`):
        ``period`` (samples), ``lines`` (first, last), ``periods`` kept, ``transient_periods`` dropped,
        ``phases`` (``"random"``: drawn from the seed; ``"benchmark"``: the Bouc-Wen benchmark's, read from
        its training file) and ``oversample`` (RK4 sub-steps per sample). The record is the periodic steady
        state (``meta["periodic"]``), its force sampled, not held.
    """

    name: str
    description: str
    terms: str
    coefficients: Mapping[str, float]
    mass: float
    g: float
    fs: float
    duration: float
    force_rms: float
    band: tuple[float, float] | None = None
    excitation: str = "force"
    x0: tuple[float, float] = (0.0, 0.0)
    reference: str = ""
    sine: Mapping[str, Any] | None = None
    multisine: Mapping[str, Any] | None = None

    def __post_init__(self) -> None:
        if self.multisine is not None:
            spec = dict(self.multisine)
            if set(spec) != set(MULTISINE_KEYS) or spec["phases"] not in ("random", "benchmark"):
                raise InputError(
                    f"preset {self.name!r}: multisine needs exactly {', '.join(MULTISINE_KEYS)} (phases 'random' "
                    f"or 'benchmark'), got {brief(spec)}"
                )
            if round(self.duration * self.fs) != int(spec["period"]) * int(spec["periods"]):
                raise InputError(
                    f"preset {self.name!r}: a multisine record is {spec['periods']} periods of {spec['period']} "
                    f"samples ({int(spec['period']) * int(spec['periods']) / self.fs:g} s at {self.fs:g} Hz); "
                    "its duration is not set separately"
                )
        for name, rule in (("mass", MASS), ("fs", FS), ("duration", DURATION)):
            rule.check(getattr(self, name), f"preset {self.name!r}: {name}")
        for name in ("g", "force_rms"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise InputError(f"preset {self.name!r}: {name} must be a finite number, got {value!r}")
        if self.force_rms < 0 or self.g < 0:
            raise InputError(f"preset {self.name!r}: force_rms and g must not be negative")
        check_samples(self.duration, self.fs, where=f"preset {self.name!r}: ")
        if not (isinstance(self.x0, (tuple, list)) and len(self.x0) == 2):
            raise InputError(f"preset {self.name!r}: x0 must be (displacement, velocity), got {brief(self.x0)}")
        for i, x in enumerate(self.x0):
            if not _finite(x):
                raise InputError(f"preset {self.name!r}: x0[{i}] must be a finite number, got {x!r}")
        _check_coefficients(self)
        for name in ("terms", "reference", "description"):
            if not isinstance(getattr(self, name), str):
                raise InputError(f"preset {self.name!r}: {name} must be text, got {brief(getattr(self, name))}")
        if self.excitation not in ("force", "base"):
            raise InputError(f"preset {self.name!r}: excitation must be 'force' or 'base', got {self.excitation!r}")
        _check_band(self)

    @property
    def n(self) -> int:
        """Number of samples (a sine test's own length)."""
        if self.sine is not None:
            return int(self.force(0).size)
        if self.multisine is not None:
            return int(self.multisine["period"]) * int(self.multisine["periods"])
        return int(round(self.duration * self.fs))

    def model(self) -> Model:
        """The true model; ``px(z)`` takes its roots from the true stiffness (Eq. 11)."""
        from ..model.physics import stiffness_roots
        from ..model.terms import Model

        model = Model.from_spec(self.terms)
        if model.uses_px:
            model = model.with_px_roots(stiffness_roots(model, dict(self.coefficients)))
        return model

    def truth(self) -> dict[str, Any]:
        """Reference values: coefficients by canonical name, mass, g, px roots."""
        model = self.model()
        coeffs = model.as_dict(model.vector(dict(self.coefficients)))
        return {
            "coefficients": coeffs,
            "mass": self.mass,
            "g": self.g,
            "px_roots": None if model.px_roots is None else list(model.px_roots),
        }

    def with_overrides(self, **overrides: Any) -> Preset:
        """A copy with fields or coefficients changed.

        Parameters
        ----------
        **overrides
            Preset fields (``mass``, ``force_rms``, ``duration``, ``fs``,
            ``band``...) and/or ``coefficients={term: value}`` (merged into the
            preset's coefficients; a changed mass also changes ``m g``
            unless the ``1`` coefficient is given).
        """
        allowed = override_fields(self, overrides)
        coeffs = dict(self.coefficients)
        new = dict(overrides)
        if "coefficients" in new:
            from ..model.terms import Model

            model = Model.from_spec(new.get("terms", self.terms))
            for key, value in dict(new.pop("coefficients")).items():
                try:
                    name = model.terms[model.index(key)].name
                except TermError:
                    raise InputError(
                        f"{brief(key)} is neither a preset parameter{did_you_mean(key, sorted(allowed))}"
                        f" ({', '.join(sorted(allowed - {'coefficients'}))}) nor a term of the model ({model})"
                    ) from None
                if isinstance(value, bool) or not isinstance(value, numbers.Real):
                    raise InputError(f"the coefficient of {name} must be a number, got {value!r}")
                coeffs[name] = float(value)
        if ("mass" in new or "g" in new) and "1" not in dict(overrides.get("coefficients", {})):
            coeffs["1"] = float(new.get("mass", self.mass)) * float(new.get("g", self.g))
        return replace(self, coefficients=coeffs, **new)

    def response_groups(self, channels: Sequence[str]) -> tuple[str, ...]:
        """The response quantities ``channels`` name: one DOF's channels are their own (as a structure preset's)."""
        return tuple(channels)

    def force(self, seed: int) -> np.ndarray:
        """The force record of a seed (N); a sine test's does not depend on the seed."""
        import numpy as np

        from . import random_force

        streams = np.random.SeedSequence(check_seed(seed)).spawn(4)
        if self.sine is not None:
            return self.sine_test().force(self.fs)[0]
        if self.multisine is not None:
            return np.tile(self._multisine_period(streams[0]), int(self.multisine["periods"]))
        return random_force(self.n, self.fs, self.force_rms, np.random.default_rng(streams[0]), self.band)

    def _multisine_period(self, stream: np.random.SeedSequence) -> np.ndarray:
        """One period of the multisine force: random phases from the force's stream, or the benchmark's."""
        import numpy as np

        from .multisine import benchmark_phases, multisine_period

        spec = self.multisine or {}
        period, lines = int(spec["period"]), tuple(spec["lines"])
        if spec["phases"] == "benchmark":
            phases = benchmark_phases(period, lines)
        else:
            phases = np.random.default_rng(stream).uniform(0.0, 2.0 * np.pi, int(lines[1]) - int(lines[0]) + 1)
        return multisine_period(period, lines, self.force_rms, phases)

    def sine_test(self) -> Any:
        """The :class:`nlid.simulation.SineTest` of a sine preset (``None`` for a random force)."""
        if self.sine is None:
            return None
        from . import SineTest

        return SineTest(**{k: tuple(v) if isinstance(v, list) else v for k, v in dict(self.sine).items()})

    def simulate(
        self,
        seed: int = 0,
        *,
        noise: float | Mapping[str, float] = 0.0,
        channels: Sequence[str] = RESPONSE_CHANNELS,
    ) -> Record:
        """Simulate one record.

        Parameters
        ----------
        seed
            Seed of the force and of the noise.
        noise
            Measurement noise as a fraction of each response channel's
            standard deviation: one number for every channel written, or a
            mapping such as ``{"z": 0.02}``. The force stays clean.
        channels
            Response channels to include (``z`` is always included).

        Returns
        -------
        Record
            With ``meta`` holding ``mass``, ``g``, ``source``, ``reference`` (the truth),
            ``seed`` and ``noise``.
        """
        import numpy as np

        from ..data.record import Record
        from . import simulate

        seed = check_seed(seed)
        channels = tuple(dict.fromkeys(("z", *channels)))
        for c in channels:
            if c not in RESPONSE_CHANNELS:
                raise InputError(f"unknown channel {brief(c)}; response channels are z, v, a")
        levels = check_noise(noise, channels)
        model = self.model()
        streams = np.random.SeedSequence(seed).spawn(4)
        if self.multisine is not None:  # the periodic steady state, the force sampled (not held)
            from .multisine import periodic_response

            spec = self.multisine
            f, z, v, a = periodic_response(
                model,
                dict(self.coefficients),
                self.mass,
                self._multisine_period(streams[0]),
                self.fs,
                periods=int(spec["periods"]),
                transient_periods=int(spec["transient_periods"]),
                oversample=int(spec["oversample"]),
            )
        else:
            f = self.force(seed)
            z, v, a = simulate(model, dict(self.coefficients), self.mass, f, self.fs, self.x0)
        exact = {"z": z, "v": v, "a": a}
        out = {}
        for c, stream in zip(RESPONSE_CHANNELS, streams[1:], strict=True):
            if c not in channels:
                continue
            x = exact[c]
            if levels[c] > 0:
                x = x + levels[c] * x.std() * np.random.default_rng(stream).standard_normal(x.size)
            out[c] = x
        meta = {
            "mass": self.mass,
            "g": self.g,
            "source": f"preset:{self.name} seed={seed} noise={_fmt_levels(levels)}",
            "preset": self.name,
            "seed": int(seed),
            "noise": levels,
            "excitation": self.excitation,
            "force_hold": "zoh" if self.multisine is None else "sampled",
            "force_hold_source": "simulation",
            "reference": self.truth(),
        }
        if self.multisine is not None:
            meta["periodic"] = int(self.multisine["period"])
            meta["signal"] = {"kind": "multisine", **{k: self.multisine[k] for k in ("period", "lines", "phases")}}
        test = self.sine_test()
        if test is not None:
            meta["signal"] = {
                "kind": f"{test.kind}-sine",
                "amplitude": test.amplitude,
                "band": list(test.band),
                "directions": test.directions,
                "steps": test.force(self.fs)[1],
            }
        return Record(f=f, fs=self.fs, meta=meta, **out)


def _fmt_levels(levels: Mapping[str, float]) -> str:
    values = set(levels.values())
    if len(values) == 1:
        return f"{values.pop():g}"
    return ",".join(f"{c}:{x:g}" for c, x in levels.items())


_G = 9.81


def _paper_numerical_system() -> dict[str, Any]:
    """The paper's numerical oscillator (Sec. 3, Eq. 21), shared by the presets that excite it differently."""
    return {
        "terms": "z^3, z^2, v*|v|",
        "coefficients": {"z^3": 1e6, "z^2": 5e3, "z": -500.0, "v": 1.0, "v*|v|": 5.0, "1": 0.2 * _G},
        "mass": 0.2,
        "g": _G,
    }


#: The Bouc-Wen benchmark's system in nlid's terms (nlid.data.datasets.BOUC_WEN_REFERENCE): k, c, alpha.
_BOUC_WEN = {"z": 5e4, "v": 10.0, "bouc_wen(800, -1100)": 5e4, "1": 0.0}

PRESETS: dict[str, Preset | StructurePreset] = {
    p.name: p
    for p in (
        Preset(
            name="paper-numerical",
            description="Double-well Duffing oscillator with quadratic damping (paper Sec. 3, Eq. 21)",
            **_paper_numerical_system(),
            fs=2048.0,
            duration=60.0,
            force_rms=50.0,
            reference="Zhu et al., Sec. 3 and Tables 1-4",
        ),
        Preset(
            name="paper-experimental",
            description="Analogue of the paper's rig: position-dependent friction of Eq. 24 (Sec. 4, Table 5)",
            terms="z^3, z^2, sign(v)*|px(z)|, v*|px(z)|, v*|v|*|px(z)|, v^3*|px(z)|",
            coefficients={
                "z^3": 7.57e5,
                "z^2": 986.0,
                "z": -565.0,
                "v": 4.26,
                "1": 0.265 * _G,
                "sign(v)*|px(z)|": 1.51,
                "v*|px(z)|": -1.32,
                "v*|v|*|px(z)|": -5.86,
                "v^3*|px(z)|": 1.84,
            },
            mass=0.265,
            g=_G,
            fs=512.0,
            duration=120.0,
            force_rms=10.0,
            band=(0.0, 100.0),
            excitation="base",
            reference="Zhu et al., Sec. 4 and Tables 5-7",
        ),
        Preset(
            name="paper-numerical-stepped",
            description="paper-numerical under a stepped sine of 2 N, 4-20 Hz up then down (measured FRF points)",
            **_paper_numerical_system(),
            fs=512.0,
            duration=268.0,
            force_rms=2.0 / math.sqrt(2.0),
            x0=(-0.0266, 0.0),
            sine={"kind": "stepped", "amplitude": 2.0, "band": (4.0, 20.0), "steps": 33, "periods": 40},
            reference="Zhu et al., Sec. 3 (the oscillator); a stepped-sine test of it",
        ),
        Preset(
            name="paper-numerical-swept",
            description="paper-numerical under a sine of 2 N swept 4-20 Hz at 0.05 Hz/s, up then down",
            **_paper_numerical_system(),
            fs=512.0,
            duration=640.0,
            force_rms=2.0 / math.sqrt(2.0),
            x0=(-0.0266, 0.0),
            sine={"kind": "swept", "amplitude": 2.0, "band": (4.0, 20.0), "rate": 0.05},
            reference="Zhu et al., Sec. 3 (the oscillator); a swept-sine test of it",
        ),
        *(
            Preset(
                name=name,
                description=description,
                terms="bouc_wen(800, -1100)",
                coefficients=_BOUC_WEN,
                mass=2.0,
                g=0.0,
                fs=750.0,
                duration=5 * 8192 / 750.0,
                force_rms=50.0,
                multisine={
                    "period": 8192,
                    "lines": (54, 1639),
                    "periods": 5,
                    "transient_periods": 2,
                    "phases": phases,
                    "oversample": 20,
                },
                reference="Noel & Schoukens 2016, the Bouc-Wen benchmark's system and training excitation",
            )
            for name, phases, description in (
                (
                    "bouc-wen-multisine",
                    "random",
                    "Bouc-Wen benchmark system, its training excitation (multisine 5-150 Hz, 50 N): a new "
                    "realisation per seed",
                ),
                (
                    "bouc-wen-train",
                    "benchmark",
                    "Bouc-Wen benchmark's training record regenerated (its multisine's phases read from "
                    "train_multisine.mat)",
                ),
            )
        ),
    )
}


def get_preset(name: str) -> Preset | StructurePreset:
    """The preset called ``name`` (error with a suggestion otherwise); structures of several DOFs among them."""
    try:
        return PRESETS[name]
    except KeyError:
        hint = did_you_mean(name, PRESETS)
        raise InputError(f"unknown preset {brief(name)}{hint}; available: {', '.join(PRESETS)}") from None


# Structures with several degrees of freedom (nlid.simulation.structure_presets): one table, so that get_preset,
# nlid.simulate and `nlid simulate --help` know them too.
PRESETS.update(STRUCTURE_PRESETS)
