"""Schema 1: lots, items, figures, checks -- the tables the hand-written DB-API layer created
(a database it wrote is stamped at this revision, then upgraded).

Revision ID: 0001
"""

import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table("lots",
                    sa.Column("lot_id", sa.Integer, primary_key=True, autoincrement=False),
                    sa.Column("name", sa.Text, nullable=False), sa.Column("created", sa.Text, nullable=False),
                    sa.Column("ares_version", sa.Text, nullable=False),
                    sa.Column("n_items", sa.Integer, nullable=False), sa.Column("limits_set", sa.Integer, nullable=False))
    op.create_table("items",
                    sa.Column("lot_id", sa.Integer, sa.ForeignKey("lots.lot_id"), primary_key=True, autoincrement=False),
                    sa.Column("idx", sa.Integer, primary_key=True, autoincrement=False),
                    sa.Column("item", sa.Text, nullable=False), sa.Column("serial", sa.Text), sa.Column("wafer", sa.Text),
                    sa.Column("x", sa.Double), sa.Column("y", sa.Double), sa.Column("kind", sa.Text),
                    sa.Column("status", sa.Text, nullable=False), sa.Column("verdict", sa.Text, nullable=False),
                    sa.Column("error", sa.Text), sa.Column("run_dir", sa.Text), sa.Column("content_hash", sa.Text),
                    sa.Column("ares_version", sa.Text), sa.Column("started", sa.Text))
    op.create_table("figures",
                    sa.Column("lot_id", sa.Integer, primary_key=True, autoincrement=False),
                    sa.Column("idx", sa.Integer, primary_key=True, autoincrement=False),
                    sa.Column("quantity", sa.Text, primary_key=True),
                    sa.Column("value", sa.Double), sa.Column("se", sa.Double), sa.Column("unit", sa.Text),
                    sa.Column("verdict", sa.Text))
    op.create_table("checks",
                    sa.Column("lot_id", sa.Integer, primary_key=True, autoincrement=False),
                    sa.Column("idx", sa.Integer, primary_key=True, autoincrement=False),
                    sa.Column("limit_text", sa.Text, primary_key=True),
                    sa.Column("outcome", sa.Text, nullable=False))
    op.create_index("figures_quantity", "figures", ["quantity"])


def downgrade() -> None:
    for t in ("checks", "figures", "items", "lots"):
        op.drop_table(t)
