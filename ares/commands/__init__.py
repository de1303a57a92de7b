"""One module per ``ares`` sub-command (see ares/cli.py)."""
