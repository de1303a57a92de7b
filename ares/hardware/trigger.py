"""How a frame is started and what the device signals while it exposes: ``<trigger mode line
edge timeout_ms strobe strobe_line>`` of a ``<usb_grabber>`` or ``<genicam>``. Pure data:
``ares.protocol.devices`` reads it from XML; ``ares.hardware.usb`` and ``ares.hardware.genicam``
honour it."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Trigger:
    """``free_run`` (the device streams), ``software`` (a frame per trigger command the host
    sends), ``hardware`` (a frame per edge on input ``line``: none arrives until the line fires;
    ``timeout_ms`` is how long the host waits for one, default the device's read timeout);
    ``strobe="exposure"``: output ``strobe_line`` is high while a frame exposes."""

    mode: str = "free_run"
    line: int = 0
    edge: str = "rising"
    timeout_ms: int | None = None
    strobe: str = "off"
    strobe_line: int = 1


TRIGGER_CODES = {"free_run": 0, "software": 1, "hardware": 2}  # a USB grabber's trigger-mode request value


def usb_request(t: Trigger | None, when: str) -> tuple[int, int]:
    """(wValue, wIndex) of a USB grabber's trigger-mode request (the mode code; the input line,
    + 0x100 for a falling edge) or strobe request (1 = high while exposing, 0 = off; the output line)."""
    t = t or Trigger()
    if when == "trigger_mode":
        return TRIGGER_CODES[t.mode], t.line | (0x100 if t.edge == "falling" else 0)
    return (1 if t.strobe == "exposure" else 0), t.strobe_line
