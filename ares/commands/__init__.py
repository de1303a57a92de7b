"""One module per ``ares`` sub-command (see ares/cli.py), and two they share: ``argtypes`` (the
options' physical types) and ``jsonable`` (a result as JSON).

May import every package but ``gui`` (the window's own command is ``ares.gui.command``)."""
