"""Tampering with a recorded version as someone with write access to the store could.

:func:`tampered_version` copies a version's model directory, edits its bundle, rewrites the
manifest to match the edited files and registers the copy as a new version whose manifest
digest tag matches too, so every digest agrees and only the checks of the contents can
refuse it. The original artifacts are never touched (stores copied per test may share them).
"""
from __future__ import annotations

import json
import pathlib
import shutil
import urllib.parse
from typing import Callable

from registry.store import naming
from registry.write.artifacts import MANIFEST_FILE, sha256_bytes


def model_path(registry, asset_id: str, version: int | str) -> pathlib.Path:
    """The local directory of a version's model (a ``file:`` source)."""
    source = registry.backend.client.get_model_version(naming.model_name(asset_id),
                                                       str(version)).source
    return pathlib.Path(urllib.parse.unquote(urllib.parse.urlparse(source).path))


def edit_json(name: str, change: Callable[[dict], None]) -> Callable[[pathlib.Path], None]:
    """A bundle edit: parse ``name``, ``change`` the dict in place, write it back (NaN and
    Infinity written as JSON's ``NaN`` / ``Infinity``, as Python's json does)."""
    def edit(bundle: pathlib.Path) -> None:
        data = json.loads((bundle / name).read_text())
        change(data)
        (bundle / name).write_text(json.dumps(data, indent=2))
    return edit


def write_bytes(name: str, data: bytes) -> Callable[[pathlib.Path], None]:
    """A bundle edit: replace file ``name`` with ``data``."""
    def edit(bundle: pathlib.Path) -> None:
        (bundle / name).write_bytes(data)
    return edit


def tampered_version(registry, asset_id: str, version: int, directory: pathlib.Path,
                     edit: Callable[[pathlib.Path], None], source: str | None = None) -> int:
    """Register an edited copy of ``version`` (manifest and digest tag consistent).

    Parameters
    ----------
    directory : path
        Where the copy goes (a test's tmp_path).
    edit : callable
        Changes the files of the copied bundle directory.
    source : str, optional
        The new version's source (default: the copy as a ``file://`` URI).

    Returns
    -------
    int
        The new version's number.
    """
    client = registry.backend.client
    name = naming.model_name(asset_id)
    original = client.get_model_version(name, str(version))
    copy = directory / f"tampered-{asset_id}-v{version}"
    shutil.copytree(model_path(registry, asset_id, version), copy)
    bundle = copy / "data" / "signature"
    edit(bundle)
    manifest = json.loads((bundle / MANIFEST_FILE).read_text())
    for file in manifest["files"]:
        data = (bundle / file).read_bytes()
        manifest["files"][file] = {"sha256": sha256_bytes(data), "bytes": len(data)}
    manifest_bytes = json.dumps(manifest, indent=2, sort_keys=True).encode()
    (bundle / MANIFEST_FILE).write_bytes(manifest_bytes)
    tags = dict(original.tags or {})
    tags[naming.TAG_MANIFEST_SHA256] = sha256_bytes(manifest_bytes)
    created = client.create_model_version(name, source or copy.as_uri(),
                                          run_id=original.run_id, tags=tags)
    return int(created.version)


def move_alias(registry, asset_id: str, alias: str, version: int) -> None:
    """Move an alias by hand, as anyone can in the MLflow UI (no checks)."""
    registry.backend.client.set_registered_model_alias(naming.model_name(asset_id), alias,
                                                       str(version))


def snapshot(registry, assets) -> dict:
    """Per asset: every version with its aliases, and the watermark."""
    return {asset: ([(v.version, v.aliases) for v in registry.history(asset)],
                    registry.watermark(asset))
            for asset in assets}
