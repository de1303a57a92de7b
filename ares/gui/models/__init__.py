"""The window's models: state without Qt (regions, statistics panels, profiles, images, PTC, sweep
maps, defect counts and map, progress, views and the stage store, the Instrumentation bench,
``SessionModel``), tested without a display; the views in ``ares.gui.plots`` only draw them."""
