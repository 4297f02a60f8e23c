"""Name -> adapter lookup: two plain dicts, no framework.

An adapter is a small class with a ``load(path, **options)`` method returning
:class:`~pcnet.adapters.types.Keypoints2D` (2D) or :class:`~pcnet.adapters.types.Poses3D`
(3D). Adding one takes a class and a decorator::

    import numpy as np
    from pcnet.adapters import Poses3D, register_3d
    from pcnet.adapters.validate import load_npy

    @register_3d("my_lifter")
    class MyLifter:
        \"\"\"(T, 17, 3) H36M-17, millimetres, x right / y up / z towards the camera.\"\"\"

        def load(self, path, **options):
            arr = load_npy(path, ndim=3, num_joints=17)   # raises AdapterError on bad input
            joints = arr * np.array([1e-3, -1e-3, -1e-3], np.float32)   # mm -> m, RUB -> RDF
            return Poses3D(joints, "h36m17", units="m", source=str(path),
                           notes="my_lifter: mm -> m, y and z flipped to the camera frame")

    from pcnet.adapters import get_3d_adapter
    poses = get_3d_adapter("my_lifter").load("out.npy")

The module defining the class must be imported once for the decorator to run; the
built-in adapters are imported by ``pcnet.adapters``.
"""

from __future__ import annotations

from typing import Callable, TypeVar

from pcnet.stages.core.errors import InputError

_ADAPTERS_2D: dict[str, type] = {}
_ADAPTERS_3D: dict[str, type] = {}

T = TypeVar("T", bound=type)


def _register(table: dict[str, type], kind: str, name: str) -> Callable[[T], T]:
    def deco(cls: T) -> T:
        if not callable(getattr(cls, "load", None)):
            raise TypeError(f"{kind} adapter {name!r}: class {cls.__name__} has no load(path, **options)")
        old = table.get(name)
        # Re-registering the same class (a module reload) is harmless; two different
        # classes under one name would silently shadow each other.
        if old is not None and (old.__module__, old.__qualname__) != (cls.__module__, cls.__qualname__):
            raise ValueError(f"{kind} adapter name {name!r} is already used by {old.__module__}.{old.__qualname__}")
        table[name] = cls
        return cls

    return deco


def register_2d(name: str) -> Callable[[T], T]:
    """Class decorator: register a 2D adapter (``load`` returns ``Keypoints2D``) under ``name``.

    Raises:
        TypeError: the class has no ``load`` method.
        ValueError: ``name`` is taken by a different class.
    """
    return _register(_ADAPTERS_2D, "2D", name)


def register_3d(name: str) -> Callable[[T], T]:
    """Class decorator: register a 3D adapter (``load`` returns ``Poses3D``) under ``name``.

    Raises:
        TypeError: the class has no ``load`` method.
        ValueError: ``name`` is taken by a different class.
    """
    return _register(_ADAPTERS_3D, "3D", name)


def _get(table: dict[str, type], kind: str, name: str):
    try:
        return table[name]()
    except KeyError:
        raise InputError(f"unknown {kind} adapter {name!r}; available: {sorted(table)}") from None


def get_2d_adapter(name: str):
    """Return a new instance of the 2D adapter registered as ``name``.

    Raises:
        ValueError: unknown name (the message lists the available ones).
    """
    return _get(_ADAPTERS_2D, "2D", name)


def get_3d_adapter(name: str):
    """Return a new instance of the 3D adapter registered as ``name``.

    Raises:
        ValueError: unknown name (the message lists the available ones).
    """
    return _get(_ADAPTERS_3D, "3D", name)


def available_2d() -> list[str]:
    """Sorted names of the registered 2D adapters."""
    return sorted(_ADAPTERS_2D)


def available_3d() -> list[str]:
    """Sorted names of the registered 3D adapters."""
    return sorted(_ADAPTERS_3D)


def unregister(name: str, kind: str) -> None:
    """Remove ``name`` from the 2D (``kind="2d"``) or 3D (``kind="3d"``) table; for tests
    and plugins that replace a built-in adapter. Unknown names are ignored."""
    table = {"2d": _ADAPTERS_2D, "3d": _ADAPTERS_3D}[kind.lower()]
    table.pop(name, None)
