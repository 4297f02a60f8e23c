"""Name -> adapter lookup: two plain dicts, no framework.

An adapter is a small class with a ``load(path, **options)`` method returning
:class:`~pcnet.adapters.types.Keypoints2D` (2D) or :class:`~pcnet.adapters.types.Poses3D`
(3D). Adding one takes a class and a decorator::

    import numpy as np
    from pcnet.adapters import Poses3D, register_3d
    from pcnet.adapters.validate import checked_poses, load_npy

    @register_3d("my_lifter", records_fps=False)   # its files hold no frame rate
    class MyLifter:
        \"\"\"(T, 17, 3) H36M-17, millimetres, x right / y up / z towards the camera.\"\"\"

        def load(self, path):   # its options as named parameters: a misspelt one is refused
            arr = load_npy(path, ndim=3, num_joints=17)   # raises AdapterError on bad input
            joints = arr * np.array([1e-3, -1e-3, -1e-3], np.float32)   # mm -> m, RUB -> RDF
            joints = checked_poses(path, "poses", joints, "h36m17", "m")   # the shared checks, last
            return Poses3D(joints, "h36m17", units="m", source=str(path),
                           notes="my_lifter: mm -> m, y and z flipped to the camera frame")

    from pcnet.adapters import get_3d_adapter
    poses = get_3d_adapter("my_lifter").load("out.npy")

The module defining the class must be imported once for the decorator to run; the
built-in adapters are imported by ``pcnet.adapters``, one line each: a new built-in adapter
is its module plus that import line. The registry is the one list of adapter names and of
what pcnet needs to know about their formats (:class:`Registered`): ``pcnet run``'s
``--lifter`` and ``--keypoints2d-format`` choices and ``--person`` help,
:meth:`pcnet.pipeline.config.RunConfig.validate` and ``pcnet batch``'s frame-rate check read
it. A lifter registered in a Python process is taken by ``run_pipeline(RunConfig(lifter=...))``
there; the ``pcnet`` command offers those registered when it starts: the built-ins and the
plugins of installed packages.

A package of its own (a plugin) declares the module that registers its adapters as an entry
point of the group ``pcnet.adapters`` in its ``pyproject.toml``; ``import pcnet.adapters``
imports it after the built-ins (:func:`load_plugins`), so ``pcnet run --lifter my_lifter``
offers it (the mechanism is ``importlib.metadata`` entry points, the packaging standard)::

    [project.entry-points."pcnet.adapters"]
    my_lifter = "my_package.my_lifter"

An adapter reads one person per file, the same person in every frame: pcnet's checks of a
track switch need 2D keypoints, so an adapter that picks a person per frame by score can
blend two people unseen. It raises :class:`~pcnet.adapters.types.AdapterError` (naming file,
field, expected and found) for bad input, with the helpers of
:mod:`pcnet.adapters.validate` (``load_npy``, ``read_json``, ``json_numbers`` for a JSON
file's numbers: ``np.asarray`` of its lists would take strings and booleans, ``checked_poses``
last); anything else it raises is reported as a bug in it, with its traceback and a last line
naming the adapter's class, its package and the file.

H36M-17's joints, in their order, are ``pcnet.stages.core.conventions.H36M_JOINTS`` (pelvis,
right_hip, ..., neck_nose, head, ..., right_wrist; ``docs/CONVENTIONS.md``), the names a CSV
header gives ``--lifter generic``. A file in a joint layout of its own is remapped to H36M-17
by the adapter itself before ``checked_poses`` (as ``kinect.py`` does: :class:`Poses3D` takes
only the layouts pcnet knows), whose errors then name H36M-17's joints; say the file's own names in ``notes``, which
the run's report keeps (``inputs.lifter_notes``, with the adapter's class and package version
in ``inputs.lifter_adapter``). ``records_fps`` is ``True`` unless given: an adapter whose
files hold no frame rate must say ``False``, or ``pcnet batch`` does not ask its rows for
``fps`` before running them.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Callable, TypeVar

from pcnet.stages.core.errors import InputError


@dataclass(frozen=True)
class Registered:
    """One registry entry: the adapter class and the facts about its format that the rest of
    pcnet reads from here rather than keeping lists of names (``pcnet run``'s choices and
    help, :class:`pcnet.pipeline.config.RunConfig`'s checks, ``pcnet batch``'s row checks).

    Attributes:
        cls: the adapter class (a ``load(path, **options)`` method).
        records_fps: whether the format's files can carry their frame rate (the loaded
            ``fps``); ``False``: a run without a video needs ``fps`` given (``pcnet batch``
            refuses such a row before it runs).
        multi_track: 2D only: what a track id is in a format that holds several people's
            tracks, one of which ``person`` picks (``"AlphaPose idx"``), as ``pcnet run
            --person``'s help says it; ``None`` for a single-track format.
        folder_input: 2D only: the format's input is a folder of files (OpenPose's
            ``--write_json`` folder), not one file.
        never_metric: 3D only: the format's poses are never in metres (MotionBERT's
            image-normalised or pixel units), so a run asking for metric outputs needs
            ``height``; ``False`` where the file or its options decide, or it is metres.
        absent_joints: 3D only: the H36M-17 joints (names) the format never has, NaN in
            every frame (Kinect v1's ``neck_nose``).
    """

    cls: type
    records_fps: bool = True
    multi_track: str | None = None
    folder_input: bool = False
    never_metric: bool = False
    absent_joints: tuple[str, ...] = ()


# Name -> entry, in registration order (the order `pcnet run --help` offers them in).
_ADAPTERS_2D: dict[str, Registered] = {}
_ADAPTERS_3D: dict[str, Registered] = {}

T = TypeVar("T", bound=type)


def _register(table: dict[str, Registered], kind: str, name: str, **facts) -> Callable[[T], T]:
    def deco(cls: T) -> T:
        if not callable(getattr(cls, "load", None)):
            raise TypeError(f"{kind} adapter {name!r}: class {cls.__name__} has no load(path, **options)")
        old = table.get(name)
        # Re-registering the same class (a module reload) is harmless; two different
        # classes under one name would silently shadow each other.
        if old is not None and (old.cls.__module__, old.cls.__qualname__) != (cls.__module__, cls.__qualname__):
            raise ValueError(f"{kind} adapter name {name!r} is already used by "
                             f"{old.cls.__module__}.{old.cls.__qualname__}")
        table[name] = Registered(cls, **facts)
        return cls

    return deco


def register_2d(name: str, *, records_fps: bool = True, multi_track: str | None = None,
                folder_input: bool = False) -> Callable[[T], T]:
    """Class decorator: register a 2D adapter (``load`` returns ``Keypoints2D``) under ``name``,
    with its format's facts (:class:`Registered`): ``records_fps=False`` for files that never
    record a frame rate, ``multi_track="<what a track id is>"`` for files holding several
    people's tracks (then ``load`` takes ``person``), ``folder_input=True`` for a format read
    from a folder of files.

    Raises:
        TypeError: the class has no ``load`` method.
        ValueError: ``name`` is taken by a different class.
    """
    return _register(_ADAPTERS_2D, "2D", name, records_fps=records_fps, multi_track=multi_track,
                     folder_input=folder_input)


def register_3d(name: str, *, records_fps: bool = True, never_metric: bool = False,
                absent_joints: tuple[str, ...] = ()) -> Callable[[T], T]:
    """Class decorator: register a 3D adapter (``load`` returns ``Poses3D``) under ``name``,
    with its format's facts (:class:`Registered`): ``records_fps=False`` for files that never
    record a frame rate, ``never_metric=True`` for poses never in metres, ``absent_joints``
    the H36M-17 joints its files never have; ``pcnet run`` and ``pcnet batch``'s manifest
    check refuse what these rule out before reading a file.

    Raises:
        TypeError: the class has no ``load`` method.
        ValueError: ``name`` is taken by a different class.
    """
    return _register(_ADAPTERS_3D, "3D", name, records_fps=records_fps, never_metric=never_metric,
                     absent_joints=tuple(absent_joints))


def _get(table: dict[str, Registered], kind: str, name: str):
    try:
        return table[name].cls()
    except KeyError:
        raise InputError(f"unknown {kind} adapter {name!r}; available: {sorted(table)}") from None


def get_2d_adapter(name: str):
    """Return a new instance of the 2D adapter registered as ``name``.

    Raises:
        InputError (a ValueError): unknown name (the message lists the available ones).
    """
    return _get(_ADAPTERS_2D, "2D", name)


def get_3d_adapter(name: str):
    """Return a new instance of the 3D adapter registered as ``name``.

    Raises:
        InputError (a ValueError): unknown name (the message lists the available ones).
    """
    return _get(_ADAPTERS_3D, "3D", name)


def available_2d() -> list[str]:
    """Sorted names of the registered 2D adapters."""
    return sorted(_ADAPTERS_2D)


def available_3d() -> list[str]:
    """Sorted names of the registered 3D adapters."""
    return sorted(_ADAPTERS_3D)


def _table(kind: str) -> dict[str, Registered]:
    return {"2d": _ADAPTERS_2D, "3d": _ADAPTERS_3D}[kind.lower()]


def registered(kind: str) -> dict[str, Registered]:
    """``{name: Registered}`` of the 2D (``kind="2d"``) or 3D (``kind="3d"``) adapters in
    registration order (the built-ins in ``pcnet.adapters``' import order, then any
    registered later); a copy.

    Raises:
        KeyError: ``kind`` not ``"2d"`` or ``"3d"``.
    """
    return dict(_table(kind))


def unregister(name: str, kind: str) -> None:
    """Remove ``name`` from the 2D (``kind="2d"``) or 3D (``kind="3d"``) table; for tests
    and plugins that replace a built-in adapter. Unknown names are ignored."""
    _table(kind).pop(name, None)


#: The entry point group of adapter plugins (installed packages' modules that register adapters).
PLUGIN_GROUP = "pcnet.adapters"


class PluginWarning(UserWarning):
    """An installed adapter plugin that could not be imported (the rest of pcnet still works)."""


def load_plugins() -> list[str]:
    """Import every module declared in the ``pcnet.adapters`` entry point group of the
    installed packages (``importlib.metadata``), so that their ``register_2d`` /
    ``register_3d`` decorators run; called once by ``import pcnet.adapters``, after the
    built-ins. A plugin that fails to import (or registers a name taken) gives a
    :class:`PluginWarning` naming it and its error, and is left out.

    Returns:
        the names of the entry points imported.
    """
    loaded = []
    for point in entry_points(group=PLUGIN_GROUP):
        try:
            point.load()
        except Exception as err:  # one broken plugin must not stop pcnet: said, and left out
            warnings.warn(f"pcnet: adapter plugin {point.name!r} ({point.value}) not loaded: "
                          f"{type(err).__name__}: {err}", PluginWarning, stacklevel=2)
            continue
        loaded.append(point.name)
    return loaded
