"""The tick exchange of a run, as ``--record-inputs`` logs it and ``marsupial replay --against`` reads it back.

Each record is one message of the lockstep exchange (:mod:`marsupial.api.ticks`):
the run's :class:`~marsupial.api.ticks.TreeSetup` (``setup``), every
:class:`~marsupial.api.ticks.TickInput` the tree received (``tick`` or
``pause``; ``stop`` has none), and the commands it answered with, each with
the node that sent it (``output``). Payloads are pickled (protocol 5) with
camera images PNG-compressed (lossless, so a replay sees the very pixels the
run saw) and written base64-encoded on the JSON channel ``/replay``.

Reading a log back unpickles only what such a record may hold: the message
types of :mod:`marsupial.api`, the data classes that skills send over the team
link, numpy arrays and plain containers. Any other object in a log is refused
(:class:`ExchangeLogError`), so replaying a log from elsewhere runs no code of
the log's choosing.
"""

from __future__ import annotations

import base64
import dataclasses
import io
import pickle
from collections.abc import Callable
from typing import Any

import cv2
import numpy as np

#: the channel the records go to, and the schema that describes them (``trees/schemas.json``)
TOPIC = "/replay"
SCHEMA = "marsupial.ReplayRecord"
#: modules whose data classes a record may hold (the contract's messages and the skills' link payloads)
ALLOWED_MODULES = ("marsupial.api", "marsupial.skills")
#: other globals a record may name (numpy's array reconstruction, plain containers, the image decoder)
ALLOWED_GLOBALS = frozenset({
    ("numpy", "ndarray"), ("numpy", "dtype"), ("numpy.core.multiarray", "_reconstruct"),
    ("numpy._core.multiarray", "_reconstruct"), ("numpy.core.multiarray", "scalar"),
    ("numpy._core.multiarray", "scalar"), ("numpy._core.numeric", "_frombuffer"), ("numpy.core.numeric", "_frombuffer"),
    ("numpy", "float64"), ("numpy", "float32"), ("numpy", "int64"),
    ("numpy", "int32"), ("numpy", "uint8"), ("numpy", "bool_"),
    ("builtins", "frozenset"), ("builtins", "set"), ("builtins", "complex"), ("builtins", "slice"),
    ("collections", "deque"), ("collections", "OrderedDict"), ("copyreg", "_reconstructor"),
    ("builtins", "object"), (__name__, "png_image"),
})


class ExchangeLogError(ValueError):
    """A replay record that cannot be read: not one of the exchange's messages, or damaged."""


def png_image(data: bytes) -> np.ndarray:
    """An RGB image (``(h, w, 3)`` uint8) from the PNG bytes :func:`encode` wrote."""
    decoded = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_COLOR)
    if decoded is None:
        raise ExchangeLogError("a replay record holds an image that is no PNG")
    return cv2.cvtColor(decoded, cv2.COLOR_BGR2RGB)


class _Pickler(pickle.Pickler):
    """Pickles RGB images as PNG (lossless, a fraction of their size)."""

    def reducer_override(self, obj: Any) -> Any:
        if isinstance(obj, np.ndarray) and obj.dtype == np.uint8 and obj.ndim == 3 and obj.shape[2] == 3:
            ok, png = cv2.imencode(".png", cv2.cvtColor(np.ascontiguousarray(obj), cv2.COLOR_RGB2BGR))
            if ok:
                return png_image, (png.tobytes(),)
        return NotImplemented


class _Unpickler(pickle.Unpickler):
    """Unpickles only the exchange's data types (see the module docstring)."""

    def find_class(self, module: str, name: str) -> Any:
        if (module, name) in ALLOWED_GLOBALS:
            return super().find_class(module, name)
        if any(module == m or module.startswith(m + ".") for m in ALLOWED_MODULES):
            found = super().find_class(module, name)
            if isinstance(found, type) and (dataclasses.is_dataclass(found) or issubclass(found, tuple)):
                return found
        raise ExchangeLogError(f"a replay record names {module}.{name}, which is not one of the exchange's types")


def encode(payload: Any) -> str:
    """``payload`` pickled (images as PNG), base64 text for a JSON message."""
    buffer = io.BytesIO()
    _Pickler(buffer, protocol=5).dump(payload)
    return base64.b64encode(buffer.getvalue()).decode("ascii")


def decode(text: str) -> Any:
    """The payload :func:`encode` wrote; :class:`ExchangeLogError` for anything else."""
    try:
        return _Unpickler(io.BytesIO(base64.b64decode(text, validate=True))).load()
    except ExchangeLogError:
        raise
    except Exception as err:  # a damaged record: say so, whatever the unpickler raised
        raise ExchangeLogError(f"a replay record cannot be read: {type(err).__name__}: {err}") from None


def same(a: Any, b: Any) -> bool:
    """Whether two messages are equal, field by field (numpy arrays element by element)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and np.array_equal(a, b)
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        return type(a) is type(b) and all(
            same(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a)
        )
    compare: dict[type, Callable[[Any, Any], bool]] = {
        dict: lambda x, y: x.keys() == y.keys() and all(same(x[k], y[k]) for k in x),
        list: lambda x, y: len(x) == len(y) and all(same(u, v) for u, v in zip(x, y, strict=True)),
        tuple: lambda x, y: len(x) == len(y) and all(same(u, v) for u, v in zip(x, y, strict=True)),
    }
    for kind, equal in compare.items():
        if isinstance(a, kind):
            return isinstance(b, kind) and equal(a, b)
    return bool(a == b)
