"""Alembic's environment for the results database: always online, on the connection that
``ares.batch.dbconn`` opened (in ``config.attributes['connection']``), inside its transaction
and lock -- no ``alembic.ini``, no URL of its own."""

from alembic import context

context.configure(connection=context.config.attributes["connection"], transaction_per_migration=False)
with context.begin_transaction():
    context.run_migrations()
