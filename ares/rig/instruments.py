"""Opening a bench's instruments for a scan: one the scan does not use may fail to answer
(issue 54: a chamber that fails ``*IDN?`` must not fail a scan that never sets a temperature)."""

from __future__ import annotations


def open_instrument(role: str, opener, uses: set | None, unavailable: dict):
    """``opener()`` for the bench part ``role``; a failure is the run's only when the scan
    uses it, else it is noted in ``unavailable`` and the part is None."""
    from ares.errors import HardwareError

    try:
        return opener()
    except HardwareError as exc:
        if uses is None or role in uses:
            raise
        unavailable[role] = f"{exc} (not used by this scan)"
        return None
