"""Schema 3: the bins a lot file declares -- each soft bin's row in ``bins`` also holds its
hard bin's name and whether that hard bin is a pass bin (``hard_name``, ``pass``); a lot of
schema 2 has them empty (its bins were the fixed default: hard bin 1 the only pass bin).
``ares_schema`` says 3.

Revision ID: 0003
"""

import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("bins") as b:  # (SQLite: batch mode; PostgreSQL: plain ALTER)
        b.add_column(sa.Column("hard_name", sa.Text))
        b.add_column(sa.Column("pass", sa.Integer))
    op.execute("UPDATE ares_schema SET version = 3")


def downgrade() -> None:
    with op.batch_alter_table("bins") as b:
        b.drop_column("pass")
        b.drop_column("hard_name")
    op.execute("UPDATE ares_schema SET version = 2")
