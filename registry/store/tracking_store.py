"""Where the registry lives: tracking-URI handling, SQLite set-up, retries and per-asset locks.

Embedded default
    ``sqlite:///<workdir>/mlflow.db``, artifacts in ``<workdir>/mlartifacts``. Relative SQLite
    paths are resolved against the working directory once, so every later use (and every
    process) means the same file.
PostgreSQL
    ``postgresql://user@host:port/db`` (or ``postgres://``) is normalized to
    ``postgresql+psycopg://...``: MLflow opens it with SQLAlchemy, and psycopg 3 (the
    ``postgres`` extra) is the driver. A URI naming another driver
    (``postgresql+psycopg2://``) is kept as given. Experiments the registry creates keep
    their artifacts in ``<workdir>/mlartifacts``, an absolute path every worker must see
    alike (a shared file system); to serve artifacts to many hosts, run an ``mlflow server``
    on the database and give the workers its ``http://`` URI (docs/deployment.md).
Any other tracking URI
    (``http://host:port`` of an ``mlflow server``, a database URI) is used as given; the
    server chooses where artifacts go.

Moved embedded stores
    MLflow records absolute ``file://`` artifact URIs. An artifact URI that lies under another
    ``mlartifacts`` directory than the store's own, which no longer exists (the working
    directory was moved), is read and written under the store's own ``mlartifacts`` instead
    (:meth:`Store.local_artifact_uri`); so a moved directory (fleet.toml, mlflow.db,
    mlartifacts) keeps working. A copy whose original still exists keeps using the
    original's artifacts.

SQLite and concurrent writers
    MLflow opens SQLite with a 20 s busy timeout, but SQLite still answers "database is
    locked" at once when a read transaction must be upgraded to a write while another writer
    has committed (no busy handler runs in that case), and schema creation races when two
    processes open a new file together (MLflow PR #20014 and its issue are the known cases).
    So: the file is switched to write-ahead logging (``PRAGMA journal_mode=WAL``, persistent)
    and its tables are created under a file lock before any MLflow writer opens it, and every
    MLflow call the registry makes goes through :func:`registry.store.retry.call_with_retry`,
    which retries only "database is locked"/"database is busy" errors, with exponential
    backoff and jitter, logging each retry. The same errors relayed by an ``mlflow server`` (HTTP 500 with that
    message) are retried the same way.

Locks
    :meth:`Store.asset_lock` serializes the writes of one asset (promotions, records,
    watermark). For a local SQLite store it is an exclusive ``fcntl.flock`` on one file per
    asset beside the database, so every process using the store shares them. For a
    PostgreSQL store it is a PostgreSQL advisory lock (``pg_advisory_lock``, waiting at most
    the timeout, on a connection the store keeps per thread for its locks:
    :class:`registry.store.locks.AdvisoryLocks`), so writers on every machine exclude each other;
    the creation of MLflow's schema is serialized the same way (two processes opening a new
    database together would both migrate it). Against an ``mlflow server``
    (``http://...``) the lock files sit in the user's cache directory: they then serialize
    operations from this host only, unless ``FLEET_HEALTH_LOCK_URI`` names a PostgreSQL
    database (e.g. the server's backend store): then its advisory locks are used, and
    workers on every host exclude each other.
"""
from __future__ import annotations

import contextlib
import hashlib
import logging
import os
import pathlib
import sqlite3
import urllib.parse
import urllib.request
from dataclasses import dataclass, field
from typing import Iterator

from graybox.telemetry import validate_asset_id
from registry.store.locks import AdvisoryLocks, advisory_lock, file_lock
from registry.store.retry import RetryPolicy, call_with_retry

logger = logging.getLogger(__name__)

DEFAULT_DB_NAME = "mlflow.db"
ARTIFACTS_DIR_NAME = "mlartifacts"
LOCKS_DIR_NAME = ".fleet-health-locks"
POSTGRES_SCHEMES = ("postgresql", "postgres", "postgresql+psycopg")
#: a PostgreSQL database whose advisory locks serialize the writers of an ``mlflow server``
LOCK_URI_VARIABLE = "FLEET_HEALTH_LOCK_URI"
SCHEMA_LOCK = "fleet-health/schema"



@dataclass(frozen=True)
class Store:
    """A resolved tracking store.

    Attributes
    ----------
    tracking_uri : str
        Normalized URI (absolute path for SQLite).
    db_path : pathlib.Path or None
        The SQLite file, for an embedded store.
    artifact_root : str or None
        ``file://`` URI under which experiments created by the registry keep their artifacts
        (SQLite and PostgreSQL stores; a server decides for itself).
    lock_dir : pathlib.Path
        Where the lock files are (unused by a PostgreSQL store).
    postgres_conninfo : str or None
        The libpq URI (no SQLAlchemy driver) of the database whose advisory locks are the
        asset locks: a PostgreSQL store's own, or ``FLEET_HEALTH_LOCK_URI`` for a server.
    """

    tracking_uri: str
    db_path: pathlib.Path | None
    artifact_root: str | None
    lock_dir: pathlib.Path
    postgres_conninfo: str | None = None
    #: the asset locks' kept PostgreSQL connections (when ``postgres_conninfo``)
    advisory: AdvisoryLocks | None = field(init=False, default=None, compare=False,
                                           repr=False)

    def __post_init__(self):
        if self.postgres_conninfo is not None:
            object.__setattr__(self, "advisory", AdvisoryLocks(self.postgres_conninfo))

    @property
    def is_local(self) -> bool:
        return self.db_path is not None

    @property
    def is_postgres(self) -> bool:
        """Whether the tracking store is a PostgreSQL database (not a server in front of one)."""
        return self.tracking_uri.startswith("postgresql")

    def experiment_artifact_location(self, experiment_name: str) -> str | None:
        """Artifact location for a new experiment (None lets the server choose)."""
        if self.artifact_root is None:
            return None
        digest = hashlib.sha256(experiment_name.encode()).hexdigest()[:8]
        safe = experiment_name.replace("/", "_")
        return f"{self.artifact_root}/{safe}-{digest}"

    @contextlib.contextmanager
    def asset_lock(self, asset_id: str, timeout: float = 120.0) -> Iterator[None]:
        """Hold the exclusive lock of one asset (promotions, rejections, records, watermark).

        Raises
        ------
        RegistryError
            If the lock is not acquired within ``timeout`` seconds.
        """
        validate_asset_id(asset_id)
        if self.advisory is not None:
            lock = self.advisory.hold(f"fleet-health/asset/{asset_id}", timeout=timeout,
                                      what=f"asset {asset_id!r}")
        else:
            lock = file_lock(self.lock_dir / f"{asset_id}.lock", timeout=timeout,
                             what=f"asset {asset_id!r}")
        with lock:
            yield

    @contextlib.contextmanager
    def asset_locks(self, asset_ids, timeout: float = 120.0
                    ) -> Iterator[dict[str, Exception]]:
        """Hold the locks of several assets together (a group's records or watermarks).

        They are taken in sorted order, so two holders of overlapping groups never wait for
        each other in a cycle. Yields the assets whose lock could not be taken (the
        ``RegistryError`` of :meth:`asset_lock`); the others are held.

        Raises
        ------
        ConnectionError
            If a PostgreSQL store cannot be reached (the locks taken are released).
        """
        from registry.exceptions import RegistryError

        refused: dict[str, Exception] = {}
        with contextlib.ExitStack() as stack:
            for asset_id in sorted(set(asset_ids)):
                try:
                    stack.enter_context(self.asset_lock(asset_id, timeout))
                except RegistryError as error:
                    refused[asset_id] = error
            yield refused

    def local_artifact_uri(self, uri: str) -> str:
        """Where an artifact URI recorded in this store is now.

        For an embedded (SQLite) store, a ``file://`` URI under another ``mlartifacts``
        directory than the store's own, when that directory no longer exists (the store was
        moved), is rebased on the store's own; any other URI is returned unchanged.
        """
        if self.db_path is None or self.artifact_root is None or not uri.startswith("file:"):
            return uri     # a shared store's paths mean the same on every host: never rebased
        path = pathlib.PurePosixPath(_file_uri_path(uri))
        parts = path.parts
        if ARTIFACTS_DIR_NAME not in parts:
            return uri
        cut = len(parts) - parts[::-1].index(ARTIFACTS_DIR_NAME)
        recorded_root = pathlib.PurePosixPath(*parts[:cut])
        own_root = pathlib.PurePosixPath(_file_uri_path(self.artifact_root))
        if recorded_root == own_root or os.path.isdir(recorded_root):
            return uri
        return pathlib.Path(own_root, *parts[cut:]).as_uri()


def _file_uri_path(uri: str) -> str:
    return urllib.request.url2pathname(urllib.parse.urlparse(uri).path)


def default_tracking_uri(workdir: str | os.PathLike | None = None) -> str:
    """The embedded store, ``sqlite:///<workdir>/mlflow.db`` (workdir defaults to the cwd)."""
    base = pathlib.Path(workdir) if workdir is not None else pathlib.Path.cwd()
    return "sqlite:///" + str((base / DEFAULT_DB_NAME).resolve())


def resolve_store(tracking_uri: str | None = None,
                  workdir: str | os.PathLike | None = None) -> Store:
    """Normalize a tracking URI and decide where artifacts and locks go.

    Parameters
    ----------
    tracking_uri : str, optional
        ``sqlite:///relative.db`` (resolved against ``workdir``), ``sqlite:////abs.db``,
        ``http(s)://...`` or another MLflow database URI. None means the embedded default.
    workdir : path-like, optional
        Base of relative SQLite paths and of the default; the current directory if omitted.

    Returns
    -------
    Store

    Notes
    -----
    ``postgresql://`` and ``postgres://`` become ``postgresql+psycopg://`` (SQLAlchemy's
    name for psycopg 3); a URI that names its driver is kept.
    """
    if tracking_uri is None:
        tracking_uri = default_tracking_uri(workdir)
    if not isinstance(tracking_uri, str) or not tracking_uri:
        raise ValueError(f"tracking URI must be a non-empty string, got {tracking_uri!r}")
    if tracking_uri.startswith("sqlite:"):
        if not tracking_uri.startswith("sqlite:///") or tracking_uri in ("sqlite:///", "sqlite:///:memory:"):
            raise ValueError(f"SQLite tracking URI {tracking_uri!r} must name a file: "
                             f"sqlite:///relative/path.db or sqlite:////absolute/path.db")
        raw = tracking_uri[len("sqlite:///"):].split("?", 1)[0]
        path = pathlib.Path(raw)
        if not path.is_absolute():
            path = (pathlib.Path(workdir) if workdir is not None else pathlib.Path.cwd()) / path
        path = path.resolve()
        return Store("sqlite:///" + str(path), path, (path.parent / ARTIFACTS_DIR_NAME).as_uri(),
                     path.parent / LOCKS_DIR_NAME)
    scheme = tracking_uri.split("://", 1)[0].lower()
    if scheme in POSTGRES_SCHEMES or scheme.startswith("postgresql+"):
        return _postgres_store(tracking_uri, workdir)
    if "://" not in tracking_uri:
        raise ValueError(f"tracking URI {tracking_uri!r} is not a URI: use sqlite:///path.db for "
                         f"the embedded store or http://host:port for an MLflow server")
    cache = pathlib.Path(os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache")
    digest = hashlib.sha256(tracking_uri.encode()).hexdigest()[:16]
    lock_uri = os.environ.get(LOCK_URI_VARIABLE)
    return Store(tracking_uri.rstrip("/"), None, None, cache / "fleet-health" / "locks" / digest,
                 postgres_conninfo=None if not lock_uri else _libpq_uri(lock_uri))


def _postgres_url(uri: str, what: str):
    """``uri`` parsed by SQLAlchemy (a ``URL``); a ValueError starting ``what`` + the URI when
    it is not a PostgreSQL URI."""
    from sqlalchemy.engine import make_url

    try:
        url = make_url(uri)
    except Exception as error:
        raise ValueError(f"{what}{uri!r} is not a PostgreSQL URI: {error}") from None
    if url.get_backend_name() not in ("postgresql", "postgres"):
        raise ValueError(f"{what}{uri!r} is not a PostgreSQL URI")
    return url


def _libpq(url) -> str:
    """A PostgreSQL ``URL`` without its SQLAlchemy driver (``postgresql+psycopg://`` ->
    ``postgresql://``), as libpq reads it."""
    return url.set(drivername="postgresql").render_as_string(hide_password=False)


def _libpq_uri(uri: str) -> str:
    """:func:`_libpq` of the URI named by :data:`LOCK_URI_VARIABLE`."""
    return _libpq(_postgres_url(uri, f"{LOCK_URI_VARIABLE}="))


def _postgres_store(tracking_uri: str, workdir: str | os.PathLike | None) -> Store:
    url = _postgres_url(tracking_uri, "tracking URI ")
    if url.drivername in ("postgresql", "postgres"):
        url = url.set(drivername="postgresql+psycopg")
    if not url.database:
        raise ValueError(f"PostgreSQL tracking URI {tracking_uri!r} must name a database: "
                         f"postgresql://user@host:port/database")
    normalized = url.render_as_string(hide_password=False)
    conninfo = _libpq(url)
    digest = hashlib.sha256(normalized.encode()).hexdigest()[:16]
    cache = pathlib.Path(os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache")
    base = pathlib.Path(workdir) if workdir is not None else pathlib.Path.cwd()
    return Store(normalized, None, (base.resolve() / ARTIFACTS_DIR_NAME).as_uri(),
                 cache / "fleet-health" / "locks" / digest, postgres_conninfo=conninfo)


def load_mlflow() -> None:
    """Import the registry's MLflow side now: MLflow's client and its SQLAlchemy tracking and
    model-registry stores (about 1.5 s in a fresh process), which otherwise load when the
    first registry opens.

    For a process that has time before its work: a served nightly run's process starts ahead
    of its scheduled time (:mod:`flows.serve`) and waits; what it imports then is not paid
    after the run is due.
    """
    import mlflow.store.model_registry.sqlalchemy_store  # noqa: F401
    import mlflow.store.tracking.sqlalchemy_store  # noqa: F401

    import registry.registry  # noqa: F401


def prepare_store(store: Store, policy: RetryPolicy = RetryPolicy()) -> None:
    """Make the store ready for concurrent writers (see :func:`prepare_sqlite` and
    :func:`prepare_postgres`); nothing for a server."""
    if store.db_path is not None:
        prepare_sqlite(store, policy)
    elif store.is_postgres:
        prepare_postgres(store, policy)


def _open_mlflow(store: Store, policy: RetryPolicy) -> None:
    from mlflow import MlflowClient

    client = MlflowClient(tracking_uri=store.tracking_uri, registry_uri=store.tracking_uri)
    # the first use of the URI in this process builds MLflow's store (and, on a new database,
    # its tables); doing it under the lock keeps two processes from migrating together
    call_with_retry(client.search_experiments, max_results=1, policy=policy,
                    what="open tracking store")
    call_with_retry(client.search_registered_models, max_results=1, policy=policy,
                    what="open model registry")


def prepare_postgres(store: Store, policy: RetryPolicy = RetryPolicy()) -> None:
    """Create MLflow's tables (and the tag-value index) under an advisory lock.

    Safe from many processes on many hosts at once: the first migrates the database, the
    others wait for the lock and find the schema in place.
    """
    with advisory_lock(store.postgres_conninfo, SCHEMA_LOCK, timeout=300,
                       what="the database schema"):
        _open_mlflow(store, policy)
        import psycopg

        with psycopg.connect(store.postgres_conninfo, autocommit=True) as connection:
            # looked up first: CREATE INDEX IF NOT EXISTS would wait for the writers of tags
            if connection.execute("SELECT 1 FROM pg_indexes WHERE indexname = %s",
                                  (TAG_VALUE_INDEX,)).fetchone() is None:
                # a hash index: a B-tree refuses values over ~2.7 kB, which tags may hold
                connection.execute(f"CREATE INDEX IF NOT EXISTS {TAG_VALUE_INDEX} "
                                   f"ON tags USING hash (value)")


def prepare_sqlite(store: Store, policy: RetryPolicy = RetryPolicy()) -> None:
    """Switch the store's SQLite file to WAL and create MLflow's tables, once, under a lock.

    Safe to call from many processes at once: the first creates the file and the schema,
    the others wait for the lock and find both in place.
    """
    if store.db_path is None:
        return
    store.db_path.parent.mkdir(parents=True, exist_ok=True)
    with file_lock(store.db_path.with_name(store.db_path.name + ".init.lock"), timeout=300,
                   what=f"database {store.db_path}"):
        call_with_retry(_enable_wal, store.db_path, policy=policy, what="enable WAL")
        _open_mlflow(store, policy)
        call_with_retry(_index_tag_values, store.db_path, policy=policy, what="index tag values")


def _synchronous_normal(connection, _record) -> None:
    cursor = connection.cursor()
    try:
        cursor.execute("PRAGMA synchronous=NORMAL")
    finally:
        cursor.close()


def relax_commit_sync(engine) -> None:
    """Commit without an fsync per transaction: ``PRAGMA synchronous=NORMAL`` on every new
    connection of a SQLite (WAL) engine.

    In WAL mode this keeps the database consistent; what a power loss (not a crashed or
    killed process) can undo is the last transactions committed, always a suffix in commit
    order. The registry's rules survive that: a watermark is committed after the records it
    covers, so it is never kept while they are lost, and a lost record is written again by the
    next run (recording is idempotent). It saves an fsync on each of the dozen commits of an
    asset-night. Applied once per engine (MLflow shares one engine per database URI).
    """
    from sqlalchemy import event

    if engine.dialect.name != "sqlite" or event.contains(engine, "connect", _synchronous_normal):
        return
    event.listen(engine, "connect", _synchronous_normal)
    engine.dispose()    # connections opened before the listener reopen with it


TAG_VALUE_INDEX = "fleet_health_tags_key_value"


def _index_tag_values(path: pathlib.Path) -> None:
    """An index on run tags by key and value, so that finding a fit by its key is a look-up.

    MLflow indexes run tags by (key, run): a filter on one tag's value reads every run's tag
    of that key, a cost that grows with the store (every night adds a run per asset). The
    index is ours (MLflow neither needs nor minds it); created once, then a no-op.
    """
    connection = sqlite3.connect(str(path), timeout=30)
    try:
        connection.execute(f"CREATE INDEX IF NOT EXISTS {TAG_VALUE_INDEX} ON tags (key, value)")
        connection.commit()
    finally:
        connection.close()


def _enable_wal(path: pathlib.Path) -> None:
    connection = sqlite3.connect(str(path), timeout=30)
    try:
        mode = connection.execute("PRAGMA journal_mode").fetchone()[0]
        if str(mode).lower() != "wal":
            mode = connection.execute("PRAGMA journal_mode=WAL").fetchone()[0]
            if str(mode).lower() != "wal":
                logger.warning("could not switch %s to WAL (journal_mode=%s)", path, mode)
    finally:
        connection.close()
