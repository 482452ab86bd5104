"""Every rigval error is also the matching built-in and survives pickling with its fields.

The errors live next to their layer (acquisition, processing, model, validation), all rooted at
RigvalError.
"""

from __future__ import annotations

import inspect
import pickle

import pytest

from rigval.acquisition import errors
from rigval.model import errors as model_errors
from rigval.processing import errors as processing_errors
from rigval.validation import errors as validation_errors

LAYER_MODULES = (errors, processing_errors, model_errors, validation_errors)
ERROR_CLASSES = [
    cls for module in LAYER_MODULES for _, cls in inspect.getmembers(module, inspect.isclass)
    if issubclass(cls, errors.RigvalError) and cls.__module__ == module.__name__
]

BUILTIN = {
    errors.DataFileError: OSError,
    errors.ChannelNotFoundError: KeyError,
    errors.ConfigError: ValueError,
    errors.ChannelMapError: ValueError,
    model_errors.MechanismError: ValueError,
    validation_errors.SceneError: ValueError,
    errors.UnitError: ValueError,
    errors.DataError: ValueError,
    processing_errors.AlignmentError: ValueError,
    processing_errors.DriveRateError: ValueError,
    model_errors.ModelError: RuntimeError,
    model_errors.AssemblyError: RuntimeError,
    model_errors.SingularityError: RuntimeError,
}


def test_every_error_class_is_listed() -> None:
    assert set(ERROR_CLASSES) == {errors.RigvalError, *BUILTIN}


@pytest.mark.parametrize("module", LAYER_MODULES, ids=lambda m: m.__name__)
def test_each_layer_exports_exactly_its_own_errors(module: object) -> None:
    own = {name for name, cls in inspect.getmembers(module, inspect.isclass)
           if cls.__module__ == module.__name__}
    assert set(module.__all__) == own


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
