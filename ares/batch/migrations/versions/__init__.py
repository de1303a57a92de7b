"""One Alembic script a schema version of the results database (oldest first by ``down_revision``)."""
