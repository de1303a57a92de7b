"""EMVA 1288 as each release writes it: 3.0/3.1 (``release3``), 4.0 Linear (``linear``,
``sheet``, ``graphs``), 4.0 General (``general``, ``general_table``), and the sanity pass every release's table goes
through (``sanity``: no impossible or undetermined figure is "ok"); ``gain_term``: Eq. 50's K
as the zero-signal gain in the 4.0 Linear figures in electrons and photons. Imports every room below
it (``kernels``, ``stats``, ``spatial``, ``noise``, ``ptc``)."""
