"""One module per ``ares`` sub-command (see ares/cli.py).

May import every package but ``gui`` (the window's own command is ``ares.gui.command``)."""
