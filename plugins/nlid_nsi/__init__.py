"""nlid plugin: time-domain nonlinear subspace identification (NSI).

Two identifiers, each registered under the entry-point group
``nlid.identifiers`` (``pyproject.toml``):

* ``nsi-ip`` (:class:`~nlid_nsi.ip.NSIInputPerturbation`, module
  ``nlid_nsi.ip_plugin``): NSI with a virtual input perturbation
  ``fbar = f + k~1 z`` (Zhu et al., Sec. 2.2 and 3.2, Eq. 8, 12-20, 22);
* ``nsi-shift`` (:class:`~nlid_nsi.shift.NSIZeroShift`, module
  ``nlid_nsi.shift_plugin``): NSI with the zero reference shifted to each
  stable equilibrium (Sec. 3.1).

NSI (Marchesiello & Garibaldi 2008) treats the nonlinear terms of the
restoring force as internal feedback forces of an underlying-linear system and
identifies one linear state-space model from the *extended* input
``[f, -g_1, ..., -g_p]`` to the displacement; the coefficients are ratios of
the columns of its extended FRF.

Modules: :mod:`~nlid_nsi.gram` (block-Hankel Gram by FFT and recursion),
:mod:`~nlid_nsi.subspace` (PO-MOESP, order, B), :mod:`~nlid_nsi.continuous`
(d2c, extended FRF, spectra, band, ULS), :mod:`~nlid_nsi.intersample`
(interval means), :mod:`~nlid_nsi.noise` (errors-in-variables correction),
:mod:`~nlid_nsi.reconstruction` (velocity completion, de-noising),
:mod:`~nlid_nsi.basis` and :mod:`~nlid_nsi.channels` (the model's terms as
extended inputs), :mod:`~nlid_nsi.fit` (one identification),
:mod:`~nlid_nsi.ip` and :mod:`~nlid_nsi.shift` (the identifiers). Design
decisions and measurements: ``docs/nsi.md``.

The identifiers' modules import scipy only when they identify: loading the entry points
(``nlid methods``, the registry) costs numpy and ``nlid.plugin`` alone.

Both identifiers declare ``dofs = "multi"``: on a structure record of several
DOFs they run the MIMO version, :mod:`~nlid_nsi.mimo` (subspace step with
several outputs, B, the ULS realisation, element spectra),
:mod:`~nlid_nsi.structure` (channels on the elements' relative coordinates,
input perturbation at the driven DOFs), :mod:`~nlid_nsi.structure_shift`
(zero reference per polynomial connection and well),
:mod:`~nlid_nsi.structure_noise` (errors-in-variables correction of the
Gram); :mod:`~nlid_nsi.wells` holds the histogram modes and Taylor shift both
shift variants use.
"""

from typing import Any

from .ip import NSIInputPerturbation
from .shift import NSIZeroShift

__all__ = ["NSIInputPerturbation", "NSIZeroShift", "UnstableULSError"]


def __getattr__(name: str) -> Any:
    """``UnstableULSError`` on first use: its module imports scipy, which loading the entry points must not."""
    if name == "UnstableULSError":
        from .fit import UnstableULSError

        return UnstableULSError
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
