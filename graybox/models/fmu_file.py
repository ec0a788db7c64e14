"""An FMU named by its file alone: the model spec ``fmu:<path>``.

fleet.toml may name an FMU (FMI 2.0, model exchange) as a class's white box without any
Python::

    [classes.pump]
    model = "fmu:models/pump.fmu"     # relative to fleet.toml's directory, absolute, or ~/...

:func:`file_model_class` makes the file's :class:`FMUFileModel`, a
:class:`~graybox.models.fmu.FMUModel` like the two-line subclass of :mod:`graybox.models.fmu`
(the same variables, parameters, column map and GUID fingerprint); its :meth:`~FMUFileModel.spec`
is ``fmu:`` and the file's absolute path. That is what a fit records
(:class:`~graybox.models.spec.ModelSpec`, the GUID as its ``fingerprint``) and what
:func:`~graybox.models.base.load_model` rebuilds the white box from later: in this process,
in a worker, or when a pickled model is unpickled (a pickle carries the spec, the parameters
and the columns, never a live FMU).

**One class per file and process.** Making the class reads the model description and
extracts the FMU to a temporary directory; the flows load a class's white box several times
an asset (the configuration check, the specs a baseline may name, each candidate) and a
compute worker's models come back pickled, once per asset. So the class of a path is kept
here (as ``sys.modules`` keeps a Python white box's class), and made again when the
file's inode, modification time or size changes: a replaced FMU is read afresh, and its GUID
is the one :meth:`~graybox.models.spec.ModelSpec.load` compares with the record's. The classes kept
also give a stored record the rule a Python spec has (:mod:`graybox.models.spec`): without
the specs the caller trusts, a record loads only a file whose class this process already
made (:func:`made`), so it never chooses which binary is loaded.
"""
from __future__ import annotations

import os
import pathlib
import threading
from typing import Collection

from graybox.exceptions import ModelSpecError
from graybox.models.fmu import FMUModel, import_fmpy

#: what starts the spec of an FMU file
PREFIX = "fmu:"

#: resolved path -> (the file's inode, modification time and size when read, its class)
_CLASSES: dict[pathlib.Path, tuple[tuple[int, int, int], type]] = {}
_MAKING = threading.Lock()


class FMUFileModel(FMUModel, abstract=True):
    """Base of the classes :func:`file_model_class` makes: the spec is the file's."""

    @classmethod
    def spec(cls) -> str:
        """``fmu:`` and the file's absolute path."""
        return PREFIX + str(cls.fmu_path)

    @classmethod
    def _where(cls, path: pathlib.Path) -> str:
        return f"FMU {path}"

    def __reduce__(self):
        from graybox.models.base import load_model

        return load_model, (self.spec(), dict(self.parameters), dict(self.columns))


def is_fmu_spec(spec: object) -> bool:
    """Whether ``spec`` names an FMU file (starts with ``fmu:``)."""
    return isinstance(spec, str) and spec.startswith(PREFIX)


def fmu_path(spec: str, base: str | os.PathLike | None = None) -> pathlib.Path:
    """The absolute path an ``fmu:<path>`` spec names.

    Parameters
    ----------
    spec : str
        ``fmu:`` and a path: absolute, ``~/...``, or relative to ``base``.
    base : path-like, optional
        The directory of a relative path (fleet.toml's); default the working directory.

    Raises
    ------
    ModelSpecError
        If the spec names no path.
    """
    text = spec[len(PREFIX):].strip()
    if not text:
        raise ModelSpecError(f"model spec {spec!r} names no file; write 'fmu:' and the path of "
                             f"an .fmu file, e.g. 'fmu:models/plant.fmu'")
    path = pathlib.Path(os.path.expanduser(text))
    if not path.is_absolute():
        path = pathlib.Path(base if base is not None else os.getcwd()) / path
    return path.resolve()


def fmu_spec(spec: str, base: str | os.PathLike | None = None) -> str:
    """``spec`` with its path made absolute (:func:`fmu_path`): the spec its class reports."""
    return PREFIX + str(fmu_path(spec, base))


def file_model_class(spec: str) -> type[FMUFileModel]:
    """The white-box class of the FMU file ``spec`` names, made once per file and process.

    Raises
    ------
    ModelSpecError
        Naming the file: FMPy not installed (and the extra that installs it), no such file,
        or an FMU the white box cannot use (:mod:`graybox.models.fmu`).
    """
    path = fmu_path(spec)
    try:
        import_fmpy()
    except ModelSpecError as error:
        raise ModelSpecError(f"FMU {path}: {error}") from None
    try:
        status = path.stat()
    except OSError as error:
        raise ModelSpecError(f"FMU {path}: no such file ({error.strerror or error})") from None
    if not path.is_file():
        raise ModelSpecError(f"FMU {path}: not a file")
    version = (status.st_ino, status.st_mtime_ns, status.st_size)
    with _MAKING:
        made_as, cls = _CLASSES.get(path, (None, None))
        if made_as != version:
            cls = type(path.name, (FMUFileModel,), {"fmu": str(path), "__module__": __name__,
                                                    "__qualname__": path.name})
            _CLASSES[path] = version, cls
    return cls


def moved_to(spec: str, fingerprint: str | None, specs: Collection[str]) -> str | None:
    """Where an FMU a record names (``spec``, fitted as ``fingerprint``) is now: the one
    spec of ``specs`` (the caller's trusted, configured ones) naming an FMU file with the same
    fingerprint, its GUID, at another path (the site moved, or the file); None if there is
    none, or ``spec`` is no FMU's, or it has no fingerprint. Only ``specs``' files are read
    (their model descriptions; no binary is loaded)."""
    if not is_fmu_spec(spec) or fingerprint is None:
        return None
    found = set()
    for candidate in specs:
        if not is_fmu_spec(candidate):
            continue
        try:
            cls = file_model_class(candidate)
            if cls.fingerprint() == fingerprint:
                found.add(cls.spec())
        except ModelSpecError:
            continue                # not there, or not a usable FMU: not where it moved
    return found.pop() if len(found) == 1 else None


def made(spec: str) -> bool:
    """Whether this process has made the class of the file ``spec`` names."""
    try:
        return fmu_path(spec) in _CLASSES
    except ModelSpecError:
        return False
