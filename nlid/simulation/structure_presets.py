"""Simulation presets of structures with several degrees of freedom.

Each is a :class:`StructurePreset`: the underlying linear system, the
nonlinear elements and their coefficients, the excitation and the sampling;
``nlid.simulate(name, seed=, noise=, channels=)`` makes an
indexed :class:`~nlid.data.record.Record` with the truth in ``meta["reference"]``
(:meth:`StructurePreset.truth`). They are registered with the one-DOF presets
(:func:`nlid.simulation.presets.get_preset`, ``nlid simulate --help``).

``3dof-cubic`` (after Marchesiello & Garibaldi 2008, MSSP 22, 81-101, ref. [29])
    A chain ground - m1 - m2 - m3 of three 1 kg masses joined by springs of
    1e5 N/m with dampers of 20 N s/m in parallel (stiffness-proportional
    damping), and a cubic spring from mass 3 to the ground,
    ``5e9 (z3)^3`` N. The force (white, 100 N RMS, held over each sample)
    acts on mass 1, away from the nonlinearity. 1 kHz, 60 s. The reference's
    numerical values could not be found (searched: the paper's text is not
    openly available); these are chosen as a laboratory-scale chain of the
    same topology: underlying modes at 22.5, 63.0 and 91.1 Hz, damping
    ratios 1.4, 3.9 and 5.7 %, well inside the 500 Hz band, and a cubic
    force whose RMS is about a third of the linear spring force at mass 3.
``2dof-double-well``
    The paper's numerical oscillator (Sec. 3, Eq. 21: m = 0.2 kg,
    ``1e6 x^3 + 5e3 x^2 - 500 x`` N, ``1 x' + 5 x'|x'|`` N, gravity m g)
    as the element between mass 1 and mass 2, ``x = z1 - z2``; mass 2
    (1 kg) is held to the ground by a spring of 1e5 N/m and a damper of
    10 N s/m and carries its own weight. The static relative displacement
    solves the paper's equation, so the two wells are the paper's (relative
    positions -0.0267 and 0.0172 m), with mass 2 at -1.18e-4 m in both. The
    modes per well are well separated: 13.0 and 50.7 Hz (left well), 8.5 and
    50.5 Hz (right well). The force acts on mass 1 as in the paper (white,
    50 N RMS, held), 2048 Hz, 60 s.
``beam-5mode``
    A steel cantilever (0.6 m x 25 mm x 4 mm, E = 210 GPa, 7850 kg/m^3)
    lumped at five equally spaced points (the tip carries half a lump), its
    stiffness the inverse of the Euler-Bernoulli flexibility matrix, with
    1 % modal damping on every mode. A cubic spring holds the tip to the
    ground, ``3e8 (z5)^3`` N, and a friction contact rubs at point 3:
    Coulomb friction of 0.3 N with a smoothed sign, ``tanh(v3/0.001)``
    (a velocity scale of 1 mm/s, a few percent of the contact's typical
    velocity: Coulomb-like, but the integrator needs no event detection).
    The force (white, 2 N RMS, held) acts at point 4. 2048 Hz, 60 s.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

from ..base.validate import DURATION, FS, NOISE_FRACTION, check_samples, check_seed, did_you_mean
from ..errors import InputError, NlidError, brief

if TYPE_CHECKING:  # pragma: no cover
    import numpy as np

    from ..data.record import Record
    from ..model.structure import StructuralModel

__all__ = ["StructurePreset", "STRUCTURE_PRESETS", "RESPONSE_GROUPS"]

#: Response quantities of a structure record (each for every DOF).
RESPONSE_GROUPS = ("z", "v", "a")
Matrix = tuple[tuple[float, ...], ...]


def _cantilever(parameters: Mapping[str, float]) -> tuple[Any, Any, Any]:
    """``(M, C, K)`` of a cantilever lumped at ``n`` points, modal damping ``zeta`` (module docstring)."""
    import numpy as np

    n = int(parameters["points"])
    length, width, height = parameters["length"], parameters["width"], parameters["height"]
    EI = parameters["E"] * width * height**3 / 12.0
    lump = parameters["density"] * width * height * length / n
    x = length * np.arange(1, n + 1) / n
    lo, hi = np.minimum.outer(x, x), np.maximum.outer(x, x)
    flexibility = lo**2 * (3 * hi - lo) / (6 * EI)
    K = np.linalg.inv(flexibility)
    K = 0.5 * (K + K.T)
    M = np.diag(np.r_[np.full(n - 1, lump), 0.5 * lump])
    from scipy.linalg import eigh

    w2, phi = eigh(K, M)
    w = np.sqrt(w2)
    C = M @ phi @ np.diag(2 * parameters["zeta"] * w) @ phi.T @ M
    return M, 0.5 * (C + C.T), K


_BUILDERS = {"cantilever": _cantilever}


def override_fields(preset: Any, overrides: Mapping[str, Any]) -> set[str]:
    """The fields of a preset (one DOF or a structure) ``with_overrides`` may change; InputError on an unknown one."""
    allowed = {f for f in preset.__dataclass_fields__ if f not in ("name", "description")}
    unknown = set(overrides) - allowed
    if unknown:
        bad = sorted(unknown)[0]
        known = sorted(allowed)
        raise InputError(f"unknown preset parameter {brief(bad)}{did_you_mean(bad, known)}; known: {', '.join(known)}")
    return allowed


def _finite(value: Any) -> bool:
    return not isinstance(value, bool) and isinstance(value, numbers.Real) and math.isfinite(float(value))


def _check_band(preset: Any) -> None:
    """A preset's ``band`` (one DOF or a structure) is ``None`` or ``(low, high)`` Hz below ``fs / 2``."""
    band = preset.band
    if band is None:
        return
    ok = isinstance(band, (tuple, list)) and len(band) == 2 and all(_finite(x) for x in band)
    if not ok or not 0 <= band[0] < band[1] < preset.fs / 2:
        raise InputError(
            f"preset {preset.name!r}: band must be (low, high) in Hz with 0 <= low < high < fs/2 = "
            f"{preset.fs / 2:g}, got {brief(band)}"
        )


def _check_coefficients(preset: Any) -> None:
    """Every coefficient of a preset (one DOF or a structure) is a finite number."""
    bad = [k for k, v in preset.coefficients.items() if not _finite(v)]
    if bad:
        raise InputError(f"preset {preset.name!r}: the coefficient of {bad[0]} must be a finite number")


@dataclass(frozen=True)
class StructurePreset:
    """A simulated test of a structure: the model, its truth, the excitation and the sampling.

    Attributes
    ----------
    name, description
        Identification and one-line summary.
    elements
        The nonlinear elements (:mod:`nlid.model.elements`), comma-separated.
    coefficients
        The coefficient of every element (any spelling).
    M, C, K
        Mass, damping and stiffness matrices of the underlying linear system
        (nested tuples); ``None`` when :attr:`linear` builds them.
    linear, parameters
        The name of a builder of ``(M, C, K)`` (``"cantilever"``) and its parameters.
    static
        Constant force per DOF (N; gravity), or ``None``.
    force_dofs
        The DOFs the force acts on (1-based).
    force_rms
        RMS of the force on each driven DOF (N).
    fs, duration
        Sampling frequency (Hz) and length (s).
    band
        ``(low, high)`` band of the force in Hz, ``None`` for white.
    oversample
        RK4 steps per sample (the force is held over each sample).
    z_range
        ``(min, max)`` displacement (m) of every DOF in which the truth's equilibria are searched.
    g
        Gravitational acceleration (m/s^2) the static forces use (0: none).
    reference
        Where the preset comes from.
    """

    name: str
    description: str
    elements: str
    coefficients: Mapping[str, float]
    force_dofs: tuple[int, ...]
    force_rms: float
    fs: float
    duration: float
    M: Matrix | None = None
    C: Matrix | None = None
    K: Matrix | None = None
    linear: str = ""
    parameters: Mapping[str, float] = field(default_factory=dict)
    static: tuple[float, ...] | None = None
    band: tuple[float, float] | None = None
    oversample: int = 4
    z_range: tuple[float, float] = (-0.05, 0.05)
    g: float = 0.0
    excitation: str = "force"
    reference: str = ""

    def __post_init__(self) -> None:
        for name, rule in (("fs", FS), ("duration", DURATION)):
            rule.check(getattr(self, name), f"preset {self.name!r}: {name}")
        check_samples(self.duration, self.fs, where=f"preset {self.name!r}: ")
        if not _finite(self.force_rms) or self.force_rms < 0:
            raise InputError(f"preset {self.name!r}: force_rms must be a non-negative number, got {self.force_rms!r}")
        if isinstance(self.oversample, bool) or not isinstance(self.oversample, int) or not 1 <= self.oversample <= 64:
            raise InputError(
                f"preset {self.name!r}: oversample must be an integer from 1 to 64, got {self.oversample!r}"
            )
        if (self.M is None) == (not self.linear):
            raise InputError(f"preset {self.name!r}: give the matrices M, C, K or a builder (linear=), one of them")
        if self.linear and self.linear not in _BUILDERS:
            raise InputError(f"preset {self.name!r}: unknown builder {self.linear!r}; known: {', '.join(_BUILDERS)}")
        _check_band(self)
        _check_coefficients(self)

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(round(self.duration * self.fs))

    @property
    def terms(self) -> str:
        """What ``nlid.identify`` is given as the terms of a record of this preset: its :attr:`elements`."""
        return self.elements

    def response_groups(self, channels: Sequence[str]) -> tuple[str, ...]:
        """The response quantities ``channels`` name (``z2`` is ``z``; a quantity for every DOF or for none).

        Raises
        ------
        InputError
            An unknown channel, or a quantity named for only some DOFs.
        """
        return self._groups(tuple(channels), self.model().n_dofs)

    # ------------------------------------------------------------------ the model and its truth
    def model(self) -> StructuralModel:
        """The true structure."""
        from ..model.structure import StructuralModel

        if self.linear:
            M, C, K = _BUILDERS[self.linear](self.parameters)
        else:
            M, C, K = self.M, self.C, self.K
        return StructuralModel(M, C, K, self.elements, dict(self.coefficients), self.static)

    def truth(self) -> dict[str, Any]:
        """Reference values: the structure (matrices, elements, coefficients), equilibria and modes.

        ``modes`` are the linearised modes at each stable equilibrium;
        ``linear_modes`` those of the underlying linear system (``M``, ``C``,
        ``K`` without the elements), the target of subspace methods.
        """
        from ..model.modes import linear_modes

        model = self.model()
        eq = model.equilibria(self.z_range)
        return {
            **model.to_dict(),
            "g": self.g,
            "equilibria": eq.to_dict(),
            "modes": [m.to_dict() for m in model.modes(points=eq.stable)],
            "linear_modes": linear_modes(model.M, model.C, model.K, [0.0] * model.n_dofs).to_dict(),
        }

    def with_overrides(self, **overrides: Any) -> StructurePreset:
        """A copy with fields changed, or coefficients (``coefficients={"z3^3": 4e10}``, any spelling) merged in.

        Raises
        ------
        InputError
            An unknown field (with a suggestion) or an element not in the model.
        """
        allowed = override_fields(self, overrides)
        new = dict(overrides)
        if "coefficients" in new:
            from ..model.elements import ElementSet

            spec = ElementSet.from_spec(new.get("elements", self.elements))
            theta = spec.vector(dict(self.coefficients)) if "elements" not in new else None
            merged = {} if theta is None else spec.as_dict(theta)
            for key, value in dict(new.pop("coefficients")).items():
                if not _finite(value):
                    raise InputError(f"the coefficient of {key} must be a number, got {value!r}")
                try:
                    k, sign = spec.locate(key)
                except NlidError:
                    raise InputError(
                        f"{key!r} is neither a preset parameter{did_you_mean(key, sorted(allowed))} "
                        f"nor an element of the model ({spec})"
                    ) from None
                merged[spec.names[k]] = sign * float(value)
            new["coefficients"] = merged
        if "parameters" in new:
            new["parameters"] = {**dict(self.parameters), **dict(new["parameters"])}
        for key in ("band", "z_range", "force_dofs", "static"):
            if isinstance(new.get(key), list):
                new[key] = tuple(new[key])
        return replace(self, **new)

    # ------------------------------------------------------------------ records
    def force(self, seed: int) -> np.ndarray:
        """The force of a seed (N), ``(N, n)`` with zero columns for the DOFs not driven."""
        import numpy as np

        from . import random_force

        n_dofs = self.model().n_dofs
        rng = np.random.default_rng(np.random.SeedSequence(check_seed(seed)).spawn(4)[0])
        out = np.zeros((self.n, n_dofs))
        for k in self.force_dofs:
            out[:, k - 1] = random_force(self.n, self.fs, self.force_rms, rng, self.band)
        return out

    def _levels(self, noise: float | Mapping[str, float], groups: Sequence[str], n_dofs: int) -> dict[str, float]:
        names = [f"{g}{k}" for g in groups for k in range(1, n_dofs + 1)]
        if not isinstance(noise, Mapping):
            level = NOISE_FRACTION.check(noise, "noise")
            return {c: level for c in names}
        out = {c: 0.0 for c in names}
        for key in sorted(noise, key=lambda c: len(str(c))):  # a quantity first, then its single channels
            targets = [c for c in names if c.rstrip("0123456789") == key] if key in RESPONSE_GROUPS else [key]
            if not targets or targets[0] not in out:
                raise InputError(
                    f"noise is given for channel {key!r}, which is not recorded (the channels are {', '.join(names)})"
                )
            for c in targets:
                out[c] = NOISE_FRACTION.check(noise[key], f"noise on {key}")
        return out

    def _groups(self, channels: Sequence[str], n_dofs: int) -> tuple[str, ...]:
        from ..data.columnmap import split_indexed

        groups: list[str] = ["z"]
        named: dict[str, set[int]] = {}
        for c in channels:
            if c in RESPONSE_GROUPS:
                groups.append(c)
                continue
            parts = split_indexed(c) if isinstance(c, str) else None
            if parts is None or parts[0] not in RESPONSE_GROUPS or parts[1] > n_dofs:
                raise InputError(f"unknown channel {c!r}; response channels are z, v, a (each for every DOF)")
            named.setdefault(parts[0], set()).add(parts[1])
        for g, dofs in named.items():
            if dofs != set(range(1, n_dofs + 1)):
                raise InputError(
                    f"a structure record has {g} for every DOF or for none: name {g} (or {g}1..{g}{n_dofs})"
                )
            groups.append(g)
        return tuple(g for g in RESPONSE_GROUPS if g in groups)

    def simulate(
        self,
        seed: int = 0,
        *,
        noise: float | Mapping[str, float] = 0.0,
        channels: Sequence[str] = RESPONSE_GROUPS,
    ) -> Record:
        """Simulate one record.

        Parameters
        ----------
        seed
            Seed of the force and of the noise.
        noise
            Measurement noise as a fraction of each response channel's
            standard deviation: one number for every channel written, or a
            mapping naming quantities and/or channels, ``{"z": 0.02, "a3": 0.05}``.
            The force stays clean.
        channels
            Response quantities to include (``z`` always): ``"z"``, ``"v"``,
            ``"a"``, each for every DOF (``z1, z2, z3`` is ``z``).

        Returns
        -------
        Record
            With ``meta`` holding ``mass`` (the matrix), ``g``, ``source``,
            ``preset``, ``seed``, ``noise`` (per channel) and ``reference`` (:meth:`truth`).
        """
        import numpy as np

        from ..data.record import Record
        from .structure import free_run

        seed = check_seed(seed)
        model = self.model()
        n_dofs = model.n_dofs
        groups = self._groups(tuple(channels), n_dofs)
        levels = self._levels(noise, groups, n_dofs)
        f = self.force(seed)
        z, v, a = free_run(model, f, self.fs, force_hold="zoh", oversample=self.oversample)
        exact = {"z": z, "v": v, "a": a}
        streams = np.random.SeedSequence(seed).spawn(4)
        out = {}
        for g, stream in zip(RESPONSE_GROUPS, streams[1:], strict=True):
            if g not in groups:
                continue
            x = exact[g].copy()
            noise_draw = np.random.default_rng(stream).standard_normal(x.shape)
            for k in range(n_dofs):
                level = levels[f"{g}{k + 1}"]
                if level > 0:
                    x[:, k] += level * x[:, k].std() * noise_draw[:, k]
            out[g] = x
        shown = set(levels.values())
        text = f"{shown.pop():g}" if len(shown) == 1 else ",".join(f"{c}:{x:g}" for c, x in levels.items() if x)
        meta = {
            "mass": model.M.tolist(),
            "g": self.g,
            "source": f"preset:{self.name} seed={seed} noise={text}",
            "preset": self.name,
            "seed": int(seed),
            "noise": levels,
            "excitation": self.excitation,
            "force_hold": "zoh",
            "reference": self.truth(),
        }
        return Record(f=f, fs=self.fs, meta=meta, force_dofs=self.force_dofs, indexed=True, **out)


_G = 9.81


def _chain(k: float, c: float) -> tuple[Matrix, Matrix, Matrix]:
    """A three-mass chain fixed to the ground at mass 1: unit masses, springs ``k``, dampers ``c``."""
    K = ((2 * k, -k, 0.0), (-k, 2 * k, -k), (0.0, -k, k))
    C = tuple(tuple(c / k * x for x in row) for row in K)
    return ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)), C, K


_M3, _C3, _K3 = _chain(1e5, 20.0)

STRUCTURE_PRESETS: dict[str, StructurePreset] = {
    p.name: p
    for p in (
        StructurePreset(
            name="3dof-cubic",
            description="Three-mass chain with a cubic spring to the ground (after Marchesiello & Garibaldi 2008)",
            elements="z3^3",
            coefficients={"z3^3": 5e9},
            M=_M3,
            C=_C3,
            K=_K3,
            force_dofs=(1,),
            force_rms=100.0,
            fs=1000.0,
            duration=60.0,
            oversample=8,
            z_range=(-0.01, 0.01),
            reference="Marchesiello & Garibaldi 2008, MSSP 22, 81-101 (ref. [29]); values chosen "
            "(nlid.simulation.structure_presets)",
        ),
        StructurePreset(
            name="2dof-double-well",
            description="The paper's double-well oscillator as the element between two masses",
            elements="(z1-z2)^3, (z1-z2)^2, (v1-v2)*|v1-v2|",
            coefficients={"(z1-z2)^3": 1e6, "(z1-z2)^2": 5e3, "(v1-v2)*|v1-v2|": 5.0},
            M=((0.2, 0.0), (0.0, 1.0)),
            C=((1.0, -1.0), (-1.0, 11.0)),
            K=((-500.0, 500.0), (500.0, 1e5 - 500.0)),
            static=(0.2 * _G, 1.0 * _G),
            g=_G,
            force_dofs=(1,),
            force_rms=50.0,
            fs=2048.0,
            duration=60.0,
            oversample=2,
            z_range=(-0.05, 0.05),
            reference="Zhu et al., Sec. 3 (the oscillator), coupled to a grounded second mass",
        ),
        StructurePreset(
            name="beam-5mode",
            description="Cantilever lumped at 5 points, cubic spring at the tip, friction contact at point 3",
            elements="z5^3, tanh(v3/0.001)",
            coefficients={"z5^3": 3e8, "tanh(v3/0.001)": 0.3},
            linear="cantilever",
            parameters={
                "points": 5,
                "length": 0.6,
                "width": 0.025,
                "height": 0.004,
                "E": 210e9,
                "density": 7850.0,
                "zeta": 0.01,
            },
            force_dofs=(4,),
            force_rms=2.0,
            fs=2048.0,
            duration=60.0,
            oversample=4,
            z_range=(-0.05, 0.05),
            reference="Euler-Bernoulli cantilever lumped at 5 points; values chosen, see "
            "nlid.simulation.structure_presets",
        ),
    )
}
