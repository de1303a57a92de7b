"""Opening the results database: a SQLAlchemy URL or a plain path, the engine with its lock
timeout, the Alembic upgrade to the newest schema, and every database error as one sentence.

``target`` is any SQLAlchemy URL (``sqlite:///results/lots.db``, ``postgresql+psycopg://u@h/db``;
``postgresql://`` without a driver means psycopg 3) or a plain path, which is a SQLite file.

Locks: SQLite writers take the write lock at the start of their transaction (``BEGIN
IMMEDIATE``) and wait for another writer up to ``LOCK_TIMEOUT_S`` (SQLite's busy timeout
retries within it); PostgreSQL writers lock the ``lots`` table for the append (``lock_timeout``
the same). Two ``ares batch`` processes appending at once therefore write one after the
other and lose nothing.

Errors (``ResultsDbError``, exit 5): a damaged file, a lock held past the timeout, a
read-only file or folder, a server that does not answer -- one sentence naming the database
and what to do, never a driver traceback. A schema newer than this ARES: ``InputError``.
"""

from __future__ import annotations

import contextlib
import re
from pathlib import Path

from ares.errors import InputError, StorageError

LOCK_TIMEOUT_S = 30.0  # a writer waits this long for another one's lock before giving up
CONNECT_TIMEOUT_S = 10  # a PostgreSQL server that does not answer within this is unreachable
MIGRATIONS = Path(__file__).with_name("migrations")
HEAD = "0003"  # the newest Alembic revision under migrations/versions
SCHEMA_VERSION = 3  # its number (ares_schema, as the pre-Alembic layer counted)
_URL = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*://")


class ResultsDbError(StorageError):
    """The results database cannot be read or written (damaged, locked, read-only, unreachable)."""


def url_of(target: str):
    """The SQLAlchemy URL of ``target``: a URL as given (``postgresql://`` gets psycopg 3), a
    plain path as ``sqlite:///`` that path."""
    import sqlalchemy as sa

    if not _URL.match(target):
        return sa.engine.URL.create("sqlite", database=str(Path(target)))
    try:
        url = sa.engine.make_url(target)
    except sa.exc.ArgumentError:
        raise InputError(f"{target}: not a database URL (sqlite:///path, postgresql+psycopg://user@host/db) "
                         f"nor a file path") from None
    if url.drivername in ("postgresql", "postgres"):
        url = url.set(drivername="postgresql+psycopg")
    return url


def shown(target: str) -> str:
    """The target as a sentence shows it: a path as given, a URL without its password."""
    return target if not _URL.match(target) else url_of(target).render_as_string(hide_password=True)


def sqlite_file(target: str) -> Path | None:
    """The file of a SQLite target (None: in memory, or not SQLite); a URI filename
    (``sqlite:///file:path?mode=ro&uri=true``) names the file after ``file:``."""
    url = url_of(target)
    db = url.database
    if url.get_backend_name() != "sqlite" or db in (None, "", ":memory:"):
        return None
    if url.query.get("uri") == "true" and db.startswith("file:"):
        db = db[len("file:"):]
        return None if db.startswith(":memory:") or "mode=memory" in str(url.query) else Path(db)
    return Path(db)


def sentence(target: str, exc: BaseException) -> str:
    """What went wrong with the database and what to do, in one sentence."""
    msg = " ".join(str(getattr(exc, "orig", None) or exc).split())
    low = msg.lower()
    db = f"results database {shown(target)}"
    if "locked" in low or "lock timeout" in low or "canceling statement due to lock" in low:
        return (f"{db}: locked by another writer for more than {LOCK_TIMEOUT_S:g} s; try again when it has "
                f"finished")
    if "not a database" in low or "malformed" in low or "file is encrypted" in low or "disk image" in low:
        return (f"{db}: damaged ({msg}); move it aside (ARES then starts a new one) or restore it from a backup")
    if "readonly" in low or "read-only" in low or "unable to open" in low or "permission denied" in low \
            or "not a directory" in low or "is a directory" in low or "file exists" in low:
        return f"{db}: cannot be written ({msg}); give --db a file in a writable folder"
    if "disk is full" in low or "no space" in low:
        return f"{db}: the disk is full ({msg}); free space and try again"
    if "connect" in low or "could not translate host" in low or "timeout expired" in low:
        return f"{db}: unreachable ({msg}); check that the server runs and the URL (user, host, port, database)"
    return f"{db}: {msg}"


@contextlib.contextmanager
def guarded(target: str, files: bool = True):
    """Every SQLAlchemy/driver error inside as ``ResultsDbError`` (one sentence); with
    ``files``, file-system errors too (opening: the SQLite file and its folder)."""
    import sqlalchemy as sa

    try:
        yield
    except sa.exc.SQLAlchemyError as exc:
        raise ResultsDbError(sentence(target, exc)) from None
    except OSError as exc:
        if not files:
            raise
        raise ResultsDbError(sentence(target, exc)) from None


def engine_for(target: str):
    import sqlalchemy as sa

    url = url_of(target)
    backend = url.get_backend_name()
    if backend == "sqlite":
        f = sqlite_file(target)
        if f is not None and url.query.get("mode") not in ("ro", "rw"):  # (those never create the file)
            f.parent.mkdir(parents=True, exist_ok=True)
        eng = sa.create_engine(url, poolclass=sa.pool.NullPool, connect_args={"timeout": LOCK_TIMEOUT_S})

        # pysqlite's own transaction handling is turned off and ours emitted (SQLAlchemy's
        # documented recipe), so that a writer's transaction starts with the write lock
        @sa.event.listens_for(eng, "connect")
        def _connect(dbapi_conn, _record):
            dbapi_conn.isolation_level = None
            dbapi_conn.execute("PRAGMA foreign_keys = ON")

        @sa.event.listens_for(eng, "begin")
        def _begin(conn):
            conn.exec_driver_sql("BEGIN IMMEDIATE" if conn.info.get("ares_write") else "BEGIN")

        return eng
    if backend == "postgresql":
        args = {"connect_timeout": CONNECT_TIMEOUT_S, "options": f"-c lock_timeout={int(LOCK_TIMEOUT_S * 1000)}"}
        try:
            return sa.create_engine(url, poolclass=sa.pool.NullPool, connect_args=args)
        except ImportError as exc:
            raise InputError(f"{shown(target)}: PostgreSQL needs the psycopg package "
                             f"(pip install 'psycopg[binary]'): {exc}") from None
    try:
        return sa.create_engine(url, poolclass=sa.pool.NullPool)
    except (ImportError, sa.exc.ArgumentError) as exc:
        raise InputError(f"{shown(target)}: no driver for this database ({exc})") from None


@contextlib.contextmanager
def write_lock(conn):
    """A transaction holding the database's write lock: SQLite ``BEGIN IMMEDIATE``,
    PostgreSQL the ``lots`` table locked against other writers (readers go on)."""
    conn.info["ares_write"] = True
    try:
        with conn.begin():
            if conn.dialect.name == "postgresql":
                conn.exec_driver_sql("SELECT pg_advisory_xact_lock(1288)")  # (before the tables exist, too)
            yield conn
    finally:
        conn.info.pop("ares_write", None)


def _alembic(conn):
    from alembic.config import Config

    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS))
    cfg.attributes["connection"] = conn
    return cfg


def revision(conn) -> str | None:
    """The database's Alembic revision; "0001" for one the pre-Alembic layer wrote (its
    ``ares_schema`` says 1); None for an empty database."""
    import sqlalchemy as sa
    from alembic.runtime.migration import MigrationContext

    rev = MigrationContext.configure(conn).get_current_revision()
    if rev is None and sa.inspect(conn).has_table("ares_schema"):
        v = conn.execute(sa.text("SELECT version FROM ares_schema")).scalar()
        rev = None if not v else f"{int(v):04d}"
    return rev


def migrate(conn, target: str) -> str:
    """Bring the database to ``HEAD`` (under the write lock; a database already there is not
    locked at all); its revision afterwards."""
    from alembic import command
    from alembic.script import ScriptDirectory

    with conn.begin():
        rev = revision(conn)
    if rev == HEAD:
        return rev
    known = {s.revision for s in ScriptDirectory(str(MIGRATIONS)).walk_revisions()}
    if rev is not None and rev not in known:
        raise InputError(f"results database {shown(target)}: schema version {rev} is newer than this ARES "
                         f"({HEAD}); update ARES")
    with write_lock(conn):
        from alembic.runtime.migration import MigrationContext

        rev = revision(conn)  # (another process may have migrated while this one waited)
        cfg = _alembic(conn)
        if rev is not None and MigrationContext.configure(conn).get_current_revision() is None:
            command.stamp(cfg, rev)  # a pre-Alembic database: its tables are revision ``rev``
        if rev != HEAD:
            command.upgrade(cfg, HEAD)
    return HEAD


class Db:
    """An open results database: its SQLAlchemy connection and the target as the user gave it."""

    def __init__(self, conn, target: str):
        self.conn, self.target = conn, target

    @property
    def name(self) -> str:
        return shown(self.target)


@contextlib.contextmanager
def connect(target: str):
    """The database at ``target`` brought to the newest schema, every error one sentence."""
    with guarded(target):
        eng = engine_for(target)
    conn = None
    try:
        with guarded(target):
            conn = eng.connect()
            migrate(conn, target)
        with guarded(target, files=False):  # (a file the caller writes meanwhile is not the database's)
            yield Db(conn, target)
    finally:
        if conn is not None:
            with contextlib.suppress(Exception):  # (closing rolls back what was not committed)
                conn.close()
        eng.dispose()
