"""The results database's schema history as Alembic migrations (``env.py`` and one script a
version under ``versions/``), applied by ``ares.batch.dbconn`` when a database is opened.

May import ``alembic`` and ``sqlalchemy`` only; nothing of ARES."""
