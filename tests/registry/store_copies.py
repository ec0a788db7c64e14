"""Copies of SQLite stores: a store recorded once (seconds of MLflow's schema creation or of
recording) is copied for each test that writes to it."""
from __future__ import annotations

import pathlib
import shutil
import sqlite3


def checkpointed(db: pathlib.Path) -> pathlib.Path:
    """``db`` with its write-ahead log moved into the file: a copy of the file alone is then
    the whole store."""
    connection = sqlite3.connect(db)
    connection.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    connection.close()
    return db


def copy_store(db: pathlib.Path, directory: pathlib.Path) -> str:
    """A copy of the checkpointed store ``db`` as ``directory/mlflow.db``; its tracking URI."""
    directory.mkdir(exist_ok=True)
    shutil.copy(db, directory / "mlflow.db")
    return f"sqlite:///{directory / 'mlflow.db'}"
