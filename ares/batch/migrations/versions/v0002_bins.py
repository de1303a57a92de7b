"""Schema 2: hard and soft bin per item (from the lot's limits and outlier screens) and the
lot's screens (static limits and dynamic part-average-testing limits with their centre,
robust sigma and k) and its bins (hard bin, name, count); ``ares_schema`` (the pre-Alembic version table) says 2, so an ARES
older than this refuses the database in one sentence instead of writing half a lot.

Revision ID: 0002
"""

import sqlalchemy as sa
from alembic import op

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("items") as b:  # (SQLite: batch mode; PostgreSQL: plain ALTER)
        b.add_column(sa.Column("hard_bin", sa.Integer))
        b.add_column(sa.Column("soft_bin", sa.Integer))
    op.create_table("screens",
                    sa.Column("lot_id", sa.Integer, primary_key=True, autoincrement=False),
                    sa.Column("screen", sa.Text, primary_key=True),
                    sa.Column("quantity", sa.Text, nullable=False), sa.Column("kind", sa.Text, nullable=False),
                    sa.Column("low", sa.Double), sa.Column("high", sa.Double), sa.Column("centre", sa.Double),
                    sa.Column("sigma", sa.Double), sa.Column("k", sa.Double),
                    sa.Column("n_tested", sa.Integer, nullable=False), sa.Column("n_failed", sa.Integer, nullable=False))
    op.create_table("bins",
                    sa.Column("lot_id", sa.Integer, primary_key=True, autoincrement=False),
                    sa.Column("soft_bin", sa.Integer, primary_key=True, autoincrement=False),
                    sa.Column("hard_bin", sa.Integer, nullable=False), sa.Column("name", sa.Text, nullable=False),
                    sa.Column("count", sa.Integer, nullable=False))
    conn = op.get_bind()
    if not sa.inspect(conn).has_table("ares_schema"):
        op.create_table("ares_schema", sa.Column("version", sa.Integer, nullable=False))
        op.execute("INSERT INTO ares_schema (version) VALUES (2)")
    else:
        op.execute("UPDATE ares_schema SET version = 2")


def downgrade() -> None:
    op.drop_table("bins")
    op.drop_table("screens")
    with op.batch_alter_table("items") as b:
        b.drop_column("soft_bin")
        b.drop_column("hard_bin")
