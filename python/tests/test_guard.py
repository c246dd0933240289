"""A Rust panic reaches Python as kanedyn.InternalError, and the exception classes are usable."""

import pickle

import pytest

import kanedyn
from kanedyn import _kanedyn


def test_a_panic_becomes_internal_error():
    # No public call is known to panic, so the guard every entry point uses is driven directly.
    with pytest.raises(kanedyn.InternalError) as e:
        _kanedyn._panic_for_test("boom at step 3")
    assert "boom at step 3" in str(e.value) and "internal error in kanedyn" in str(e.value)
    # PyO3's own PanicException derives from BaseException only; this one is an Exception.
    assert isinstance(e.value, Exception) and isinstance(e.value, kanedyn.KanedynError)
    # The interpreter and the module carry on.
    assert kanedyn.Mechanism.from_str(
        'Mechanism(name: "m", bodies: [Body(name: "b", mass: 1.0, inertia: 0.1)], '
        'joints: [Joint(name: "j", parent: "ground", child: "b")])'
    ).ndof == 1


def test_exception_hierarchy():
    for cls in (kanedyn.InputError, kanedyn.ReadError, kanedyn.ModelError, kanedyn.EngineError,
                kanedyn.ArgumentError, kanedyn.InternalError):
        assert issubclass(cls, kanedyn.KanedynError) and cls.__module__ == "kanedyn", cls
        assert cls.__doc__, cls
    assert issubclass(kanedyn.KanedynError, Exception)
    assert issubclass(kanedyn.ArgumentError, ValueError)


def test_errors_survive_pickling():
    # Errors cross process boundaries (multiprocessing, and later Dask workers).
    with pytest.raises(kanedyn.InputError) as e:
        kanedyn.Mechanism.from_str('Mechanism(name: "m", bodies: [], joints: [])', name="m.ron")
    back = pickle.loads(pickle.dumps(e.value))
    assert type(back) is kanedyn.InputError and str(back) == str(e.value)
    assert (back.file, back.line, back.column, back.field) == ("m.ron", 1, 30, "bodies")
