"""The results database's tables as SQLAlchemy Core ``Table`` objects: what the queries of
``ares.batch.db`` are written against. The DDL itself lives in the Alembic migrations
(``ares.batch.migrations``); a test checks that migrating an empty database gives exactly
these tables (``alembic.autogenerate.compare_metadata``), on SQLite and on PostgreSQL.

Tables: ``lots`` (one row a lot), ``items`` (one row an item: serial, wafer, x/y, run
directory, content hash, ARES version, start time, status, verdict, error, hard and soft
bin), ``figures`` (item x quantity: canonical name, value, SE, unit, verdict), ``checks``
(item x limit or screen: pass / FAIL / not tested), ``screens`` (lot x screen: static limits
and the dynamic part-average-testing limits the lot set itself), ``bins`` (lot x soft bin:
hard bin, name, items) and ``ares_schema`` (the
version table of the pre-Alembic layer, kept so an older ARES refuses a newer database).
"""

from __future__ import annotations

import sqlalchemy as sa

metadata = sa.MetaData()


def _key(name: str) -> sa.Column:
    return sa.Column(name, sa.Integer, primary_key=True, autoincrement=False)


lots = sa.Table("lots", metadata, _key("lot_id"),
                sa.Column("name", sa.Text, nullable=False), sa.Column("created", sa.Text, nullable=False),
                sa.Column("ares_version", sa.Text, nullable=False),
                sa.Column("n_items", sa.Integer, nullable=False), sa.Column("limits_set", sa.Integer, nullable=False))
items = sa.Table("items", metadata,
                 sa.Column("lot_id", sa.Integer, sa.ForeignKey("lots.lot_id"), primary_key=True, autoincrement=False),
                 _key("idx"),
                 sa.Column("item", sa.Text, nullable=False), sa.Column("serial", sa.Text), sa.Column("wafer", sa.Text),
                 sa.Column("x", sa.Double), sa.Column("y", sa.Double), sa.Column("kind", sa.Text),
                 sa.Column("status", sa.Text, nullable=False), sa.Column("verdict", sa.Text, nullable=False),
                 sa.Column("error", sa.Text), sa.Column("run_dir", sa.Text), sa.Column("content_hash", sa.Text),
                 sa.Column("ares_version", sa.Text), sa.Column("started", sa.Text),
                 sa.Column("hard_bin", sa.Integer), sa.Column("soft_bin", sa.Integer))
figures = sa.Table("figures", metadata, _key("lot_id"), _key("idx"), sa.Column("quantity", sa.Text, primary_key=True),
                   sa.Column("value", sa.Double), sa.Column("se", sa.Double), sa.Column("unit", sa.Text),
                   sa.Column("verdict", sa.Text),
                   sa.Index("figures_quantity", "quantity"))
checks = sa.Table("checks", metadata, _key("lot_id"), _key("idx"), sa.Column("limit_text", sa.Text, primary_key=True),
                  sa.Column("outcome", sa.Text, nullable=False))
screens = sa.Table("screens", metadata, _key("lot_id"), sa.Column("screen", sa.Text, primary_key=True),
                   sa.Column("quantity", sa.Text, nullable=False), sa.Column("kind", sa.Text, nullable=False),
                   sa.Column("low", sa.Double), sa.Column("high", sa.Double), sa.Column("centre", sa.Double),
                   sa.Column("sigma", sa.Double), sa.Column("k", sa.Double),
                   sa.Column("n_tested", sa.Integer, nullable=False), sa.Column("n_failed", sa.Integer, nullable=False))
bins = sa.Table("bins", metadata, _key("lot_id"), _key("soft_bin"), sa.Column("hard_bin", sa.Integer, nullable=False),
                sa.Column("name", sa.Text, nullable=False), sa.Column("count", sa.Integer, nullable=False),
                sa.Column("hard_name", sa.Text), sa.Column("pass", sa.Integer))
ares_schema = sa.Table("ares_schema", metadata, sa.Column("version", sa.Integer, nullable=False))
