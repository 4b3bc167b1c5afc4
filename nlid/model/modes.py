"""Linearised modes of a structure at a rest position, and the receptance (FRF) matrix.

At a stable equilibrium ``z*`` the structure behaves, for small motions, as
the linear system ``M dz'' + C_lin dz' + K_lin dz = df`` with
``K_lin = dR/dz`` and ``C_lin = dR/dz'`` at rest
(:meth:`StructuralModel.tangent_stiffness`,
:meth:`StructuralModel.tangent_damping`). :func:`modes` reports

* the complex modes of that system (the eigenvalues ``lambda`` of the
  state matrix with positive imaginary part, sorted by ``|lambda|``):
  natural frequency ``fn = |lambda| / 2 pi`` and damping ratio
  ``zeta = -Re(lambda) / |lambda|``, which hold for any (non-proportional)
  damping; their shapes are scaled to ``psi^H M psi = 1`` with the largest
  component real and positive;
* the undamped modes of ``(M, K_lin)``: frequencies and real, mass-normalised
  shapes (``Phi^T M Phi = I``, largest component positive).

An overdamped pair (real eigenvalues) has no natural frequency and is left
out of the complex modes (its count is in :attr:`StructureModes.overdamped`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from .structure import StructuralModel

__all__ = ["StructureModes", "modes", "linear_modes", "receptance"]


def _frozen(a: Any, dtype: Any = float) -> np.ndarray:
    out = np.array(a, dtype=dtype)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class StructureModes:
    """The linearised modes at one rest position.

    Attributes
    ----------
    equilibrium
        The rest position (m), one displacement per DOF.
    fn_hz, zeta
        Natural frequency (Hz) and damping ratio of each complex mode, by increasing frequency.
    shapes
        Complex mode shapes, one column per mode, ``psi^H M psi = 1``.
    undamped_hz
        Natural frequencies (Hz) of the undamped system ``(M, K_lin)``.
    undamped_shapes
        Its real mass-normalised mode shapes (``Phi^T M Phi = I``), one column per mode.
    stiffness, damping
        ``K_lin`` and ``C_lin`` (N/m, N s/m).
    overdamped
        Number of overdamped pairs left out of the complex modes.
    source
        How they were obtained (empty: linearising the model; an identifier that measures them says how).
    """

    equilibrium: tuple[float, ...]
    fn_hz: np.ndarray
    zeta: np.ndarray
    shapes: np.ndarray
    undamped_hz: np.ndarray
    undamped_shapes: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    overdamped: int = 0
    source: str = ""

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "equilibrium", tuple(float(x) for x in self.equilibrium))
        for name in ("fn_hz", "zeta", "undamped_hz", "undamped_shapes", "stiffness", "damping"):
            set_(self, name, _frozen(getattr(self, name)))
        set_(self, "shapes", _frozen(self.shapes, complex))

    def __len__(self) -> int:
        return int(self.fn_hz.size)

    def to_dict(self) -> dict[str, Any]:
        """Plain, JSON-serialisable (complex shapes as ``{"re": [...], "im": [...]}``)."""
        return {
            "equilibrium": list(self.equilibrium),
            "fn_hz": self.fn_hz.tolist(),
            "zeta": self.zeta.tolist(),
            "shapes": {"re": self.shapes.real.tolist(), "im": self.shapes.imag.tolist()},
            "undamped_hz": self.undamped_hz.tolist(),
            "undamped_shapes": self.undamped_shapes.tolist(),
            "stiffness": self.stiffness.tolist(),
            "damping": self.damping.tolist(),
            "overdamped": self.overdamped,
            "source": self.source,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> StructureModes:
        """Inverse of :meth:`to_dict`.

        Raises
        ------
        InputError
            A missing or malformed entry.
        """
        if isinstance(data, StructureModes):
            return data
        try:
            shapes = data["shapes"]
            shapes = np.asarray(shapes["re"], dtype=float) + 1j * np.asarray(shapes["im"], dtype=float)
            return cls(
                equilibrium=tuple(data["equilibrium"]),
                fn_hz=data["fn_hz"],
                zeta=data["zeta"],
                shapes=shapes,
                undamped_hz=data["undamped_hz"],
                undamped_shapes=data["undamped_shapes"],
                stiffness=data["stiffness"],
                damping=data["damping"],
                overdamped=int(data.get("overdamped", 0)),
                source=str(data.get("source") or ""),
            )
        except (KeyError, TypeError, ValueError):
            raise InputError(
                "structure modes need 'equilibrium', 'fn_hz', 'zeta', 'shapes', 'undamped_hz', "
                "'undamped_shapes', 'stiffness' and 'damping'"
            ) from None


def _largest_positive(columns: np.ndarray) -> np.ndarray:
    """Each column scaled by a unit factor making its largest-magnitude component real and positive."""
    idx = np.argmax(np.abs(columns), axis=0)
    lead = columns[idx, np.arange(columns.shape[1])]
    return columns * (np.abs(lead) / np.where(lead == 0, 1.0, lead))


def linear_modes(
    M: np.ndarray, C: np.ndarray, K: np.ndarray, equilibrium: Sequence[float], source: str = ""
) -> StructureModes:
    """The modes of ``M x'' + C x' + K x = 0`` (module docstring), reported at ``equilibrium``."""
    from scipy.linalg import eig, eigh

    M, C, K = (np.asarray(a, dtype=float) for a in (M, C, K))
    n = M.shape[0]
    w2, phi = eigh(0.5 * (K + K.T), M)
    undamped_hz = np.sqrt(np.clip(w2, 0.0, None)) / (2 * np.pi)
    phi = _largest_positive(phi)
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
    lam, vec = eig(A)
    scale = np.abs(lam).max() if lam.size else 1.0
    keep = lam.imag > 1e-9 * max(scale, 1e-300)
    lam, psi = lam[keep], vec[:n, keep]
    order = np.argsort(np.abs(lam))
    lam, psi = lam[order], psi[:, order]
    norm = np.sqrt(np.real(np.einsum("ik,ij,jk->k", psi.conj(), M, psi)))
    psi = _largest_positive(psi / np.where(norm == 0, 1.0, norm))
    return StructureModes(
        equilibrium=tuple(equilibrium),
        fn_hz=np.abs(lam) / (2 * np.pi),
        zeta=-lam.real / np.abs(lam),
        shapes=psi,
        undamped_hz=undamped_hz,
        undamped_shapes=phi,
        stiffness=K,
        damping=C,
        overdamped=int(n - lam.size),
        source=source,
    )


def modes(model: StructuralModel, point: Sequence[float]) -> StructureModes:
    """The modes of a structure linearised at the rest position ``point`` (module docstring)."""
    point = np.asarray(point, dtype=float).reshape(model.n_dofs)
    return linear_modes(model.M, model.tangent_damping(point), model.tangent_stiffness(point), point)


def receptance(M: np.ndarray, C: np.ndarray, K: np.ndarray, frequency_hz: Sequence[float]) -> np.ndarray:
    """``H(f) = (K - w^2 M + i w C)^-1`` (m/N) at each frequency: shape ``(F, n, n)``."""
    w = 2 * np.pi * np.atleast_1d(np.asarray(frequency_hz, dtype=float))
    D = K[None] - (w**2)[:, None, None] * M[None] + 1j * w[:, None, None] * C[None]
    return np.linalg.inv(D)
