"""nlid_nsi.filters: scipy.signal.lfilter's arithmetic without importing scipy.signal."""

import os
import subprocess
import sys

import numpy as np
import pytest
from scipy import signal

from nlid_nsi import filters


def _stable_den(rng, order):
    poles = rng.uniform(0.2, 0.999, order) * np.exp(1j * rng.uniform(0.0, np.pi, order))
    den = np.real(np.poly(np.concatenate([poles, poles.conj()])))
    return den * rng.uniform(0.5, 2.0)  # a[0] != 1 as well


@pytest.mark.parametrize("order", [1, 2, 3])
def test_lfilter_equals_scipy_to_the_bit(order):
    rng = np.random.default_rng(order)
    den = _stable_den(rng, order)
    num = rng.standard_normal(rng.integers(1, 2 * order + 2))
    x = rng.standard_normal((4, 777))
    assert np.array_equal(filters.lfilter(num, den, x, axis=1), signal.lfilter(num, den, x, axis=1))
    assert np.array_equal(filters.lfilter(num, den, x[0]), signal.lfilter(num, den, x[0]))
    zi = rng.standard_normal((4, max(len(num), len(den)) - 1))
    ours, zf = filters.lfilter(num, den, x, axis=1, zi=zi)
    ref, zf_ref = signal.lfilter(num, den, x, axis=1, zi=zi)
    assert np.array_equal(ours, ref)
    assert np.array_equal(zf, zf_ref)


def test_lfiltic_output_equals_scipy():
    rng = np.random.default_rng(5)
    for order in (1, 2, 4):
        den = _stable_den(rng, order)
        y_prev = float(rng.standard_normal())
        assert np.array_equal(filters.lfiltic_output(den, y_prev), signal.lfiltic([1.0], den, [y_prev]))


def test_fallback_is_scipy(monkeypatch):
    monkeypatch.setattr(filters, "_LINEAR_FILTER", [None])
    x = np.random.default_rng(1).standard_normal(300)
    den = [1.0, -1.5, 0.7]
    assert np.array_equal(filters.lfilter([0.0, 1.0], den, x), signal.lfilter([0.0, 1.0], den, x))


def test_filter_does_not_import_scipy_signal():
    code = (
        "import sys, numpy as np\n"
        "from nlid_nsi.filters import lfilter\n"
        "lfilter([1.0], [1.0, -0.5], np.ones(8))\n"
        "print('scipy.signal' in sys.modules)\n"
    )
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))  # this process's nlid_nsi
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env).stdout
    assert out.strip() == "False"


def test_nsi_ip_does_not_import_scipy_signal():
    """An ``nlid identify`` child loads what nsi-ip imports: ``scipy.signal`` (~0.5 s, ~40 MB) is not among it."""
    code = (
        "import sys\n"
        "import numpy as np\n"
        "from nlid import Record\n"
        "from nlid.plugin import Model\n"
        "from nlid_nsi import NSIInputPerturbation\n"
        "from nlid_nsi.reconstruction import oscillator_response\n"
        "rng = np.random.default_rng(0)\n"
        "f = 20 * rng.standard_normal(20000)\n"
        "z = oscillator_response(f, 1e-3, 0.2, 1.0, 500.0)[0]\n"
        "z = z + 0.01 * np.std(z) * rng.standard_normal(z.size)\n"
        "NSIInputPerturbation().identify(Record(f=f, z=z, fs=1000.0), Model.from_spec('z^3'))\n"
        "print(sorted(m for m in ('scipy.signal', 'scipy.stats') if m in sys.modules))\n"
    )
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env).stdout
    assert out.strip() == "[]"
