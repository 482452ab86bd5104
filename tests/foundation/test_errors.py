"""Every rigval error is also the matching built-in and survives pickling with its fields."""

from __future__ import annotations

import inspect
import pickle

import pytest

from rigval.acquisition import errors

ERROR_CLASSES = [
    cls for _, cls in inspect.getmembers(errors, inspect.isclass)
    if issubclass(cls, errors.RigvalError)
]

BUILTIN = {
    errors.DataFileError: OSError,
    errors.ChannelNotFoundError: KeyError,
    errors.ConfigError: ValueError,
    errors.MechanismError: ValueError,
    errors.SceneError: ValueError,
    errors.UnitError: ValueError,
    errors.DataError: ValueError,
    errors.AlignmentError: ValueError,
    errors.ModelError: RuntimeError,
    errors.AssemblyError: RuntimeError,
    errors.SingularityError: RuntimeError,
}


def test_every_error_class_is_listed() -> None:
    assert set(ERROR_CLASSES) == {errors.RigvalError, *BUILTIN}


@pytest.mark.parametrize("cls", list(BUILTIN), ids=lambda c: c.__name__)
def test_error_subclasses_matching_builtin(cls: type[errors.RigvalError]) -> None:
    with pytest.raises(BUILTIN[cls]):
        raise cls("boom")


@pytest.mark.parametrize("cls", ERROR_CLASSES, ids=lambda c: c.__name__)
def test_error_pickles_with_fields(cls: type[errors.RigvalError]) -> None:
    error = cls("channel 'acc9' not found", where={"file": "run1.tdms", "channel": "acc9",
                                                   "time_s": None},
                hint="use one of the listed channels", available=["acc1", "acc2"])
    clone = pickle.loads(pickle.dumps(error))
    assert type(clone) is cls
    assert clone.message == error.message
    assert clone.where == {"file": "run1.tdms", "channel": "acc9"}
    assert clone.hint == error.hint
    assert clone.available == ["acc1", "acc2"]
    assert str(clone) == str(error)


def test_message_says_what_where_and_how() -> None:
    error = errors.ChannelNotFoundError("no channel 'acc9'", where={"file": "run1.tdms"},
                                        hint="check the channel map", available=["acc1"])
    text = str(error)
    assert "acc9" in text and "run1.tdms" in text and "check the channel map" in text
    assert "Available: acc1" in text
