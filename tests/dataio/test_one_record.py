"""One Record for n >= 1 (issue 32): the 1-D form (one DOF) and the indexed form (a structure), one class.

The deprecated ``StructureRecord`` builds the indexed form and answers ``isinstance`` for it.
"""

from __future__ import annotations

import hashlib
import pickle

import numpy as np
import pytest

from nlid.data.digest import STRUCTURE_HASH_PREFIX, record_sha256
from nlid.data.record import Record
from nlid.data.structure_record import StructureRecord
from nlid.errors import DataError, InputError


@pytest.fixture(scope="module")
def arrays():
    rng = np.random.default_rng(32)
    return {"f": rng.standard_normal(300), "z": rng.standard_normal((300, 2)), "v": rng.standard_normal((300, 2))}


def test_the_channels_choose_the_form(arrays):
    driven = np.column_stack([arrays["f"], np.zeros(300)])  # DOF 2 is not driven
    pair = Record(f=driven, z=arrays["z"], v=arrays["v"], fs=50.0)
    assert pair.indexed and isinstance(pair, StructureRecord) and type(pair) is Record
    assert pair.n_dofs == 2 and pair.force_dofs == (1,) and pair.channels == ("f1", "z1", "z2", "v1", "v2")
    assert repr(pair) == "StructureRecord(n=300, fs=50 Hz, dofs=2, forces=f1, channels=f,z,v)"
    one = Record(f=arrays["f"], z=arrays["z"][:, 0], fs=50.0)
    assert not one.indexed and not isinstance(one, StructureRecord) and one.force_dofs is None
    assert one.n_dofs == 1 and one.channels == ("f", "z") and one.z.ndim == 1
    assert repr(one) == "Record(n=300, fs=50 Hz, channels=f,z)"
    column = Record(f=arrays["f"], z=arrays["z"][:, :1], fs=50.0)  # one column: one DOF's channel, as always
    assert not column.indexed and column.z.shape == (300,)
    n1 = Record(f=arrays["f"], z=arrays["z"][:, :1], fs=50.0, force_dofs=(1,))
    assert n1.indexed and n1.z.shape == (300, 1) and n1.channels == ("f1", "z1")
    assert not isinstance(object(), StructureRecord) and not isinstance(arrays, StructureRecord)


def test_the_alias_builds_what_record_builds(arrays):
    old = StructureRecord(arrays["f"], arrays["z"], 50.0, arrays["v"], None, 0.5, 1, {"z2": "mm"})
    new = Record(f=arrays["f"], z=arrays["z"], v=arrays["v"], fs=50.0, t0=0.5, force_dofs=1, units={"z2": "mm"})
    assert type(old) is Record and old.indexed and repr(old) == repr(new)
    assert record_sha256(old) == record_sha256(new) and dict(old.units) == dict(new.units)
    assert np.array_equal(old.channel("z2"), 1e-3 * arrays["z"][:, 1])
    with pytest.raises(DataError, match="no force acts"):
        StructureRecord(f=np.zeros((300, 2)), z=arrays["z"], fs=50.0)


def test_copies_keep_their_form(arrays):
    pair = Record(f=arrays["f"], z=arrays["z"][:, :1], fs=50.0, indexed=True)
    one = pair.dof(1)
    for record, indexed in ((pair, True), (one, False)):
        for copy in (record[::2], record.with_meta(mass=2.0), record.split(0.3)[1], pickle.loads(pickle.dumps(record))):
            assert copy.indexed is indexed and copy.n_dofs == 1
    assert one.dof(1) is one and one.as_indexed().channels == ("f1", "z1")
    assert StructureRecord.from_record(one).channels == pair.channels and pair.as_indexed() is pair
    assert pair.with_meta(mass=2.0).mass.shape == (1, 1) and one.with_meta(mass=2.0).mass == 2.0


def test_each_form_speaks_its_own_channels(arrays):
    one = Record(f=arrays["f"], z=arrays["z"][:, 0], v=arrays["v"][:, 0], fs=50.0)
    assert np.array_equal(one.channel("v"), one.v) and list(one.to_dict()) == ["t", "f", "z", "v"]
    with pytest.raises(InputError, match="record has no channel 'z1'; its channels are f, z, v"):
        one.channel("z1")
    with pytest.raises(InputError, match="dof must be a DOF number from 1 to 1"):
        one.dof(2)
    pair = one.as_indexed()
    with pytest.raises(InputError, match="for a record of one DOF"):
        pair.with_velocity_from_acceleration()
    with pytest.raises(InputError, match="force_dofs="):
        Record(f=arrays["f"], z=arrays["z"][:, 0], fs=50.0, force_dofs=(1,), indexed=False)


def test_one_digest_for_both_forms(arrays):
    pair = Record(f=arrays["f"], z=arrays["z"], fs=50.0, force_dofs=1)
    digest = hashlib.sha256(STRUCTURE_HASH_PREFIX)
    digest.update(np.array([pair.fs, pair.t0], dtype="<f8").tobytes())
    for name in ("f1", "z1", "z2"):
        digest.update(name.encode("ascii") + b"\0" + np.ascontiguousarray(pair.channel(name), dtype="<f8").tobytes())
    assert record_sha256(pair) == digest.hexdigest()
    assert record_sha256(pair.dof(1)) != record_sha256(pair.dof(1).as_indexed())
