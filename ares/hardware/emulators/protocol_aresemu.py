"""pyserial URL handler ``aresemu://NAME``: a serial port wired to the emulated instrument
registered as NAME (``ares.hardware.emulators.serial_device``). pyserial finds it once
``ares.hardware.emulators`` is in ``serial.protocol_handler_packages``."""

from __future__ import annotations

from serial.serialutil import PortNotOpenError, SerialBase, SerialException

from ares.hardware.emulators.serial_device import Late, lookup


class Serial(SerialBase):
    def open(self):
        if self._port is None:
            raise SerialException("port must be set to aresemu://NAME")
        name = str(self._port).split("://", 1)[-1].strip("/")
        self.instrument = lookup(name)
        if self.instrument is None:
            raise SerialException(f"no emulated instrument '{name}' is running")
        self._rx = bytearray()
        self._late = bytearray()  # a late reply: in the input buffer once the host's read has timed out
        self.is_open = True

    def close(self):
        self.is_open = False

    def from_url(self, url):
        return url

    @property
    def in_waiting(self):
        return len(self._rx)

    def reset_input_buffer(self):
        self._rx.clear()

    def reset_output_buffer(self):
        pass

    def _reconfigure_port(self):
        pass

    def write(self, data):
        if not self.is_open:
            raise PortNotOpenError()
        text = bytes(data).decode("ascii", "replace")
        for line in text.splitlines():
            if line.strip():
                reply = self.instrument.handle(line)
                if isinstance(reply, Late):
                    self._late += (reply + "\n").encode("ascii")
                elif isinstance(reply, list):  # lines the instrument sent unasked, then its reply
                    self._rx += "".join(r + "\n" for r in reply).encode("ascii")
                elif reply is not None:
                    self._rx += (reply + "\n").encode("ascii")
        return len(data)

    def read(self, size=1):
        if not self.is_open:
            raise PortNotOpenError()
        out = bytes(self._rx[:size])
        del self._rx[:size]
        if not out and self._late:  # the host's read timed out; the late reply arrives now
            self._rx += self._late
            self._late.clear()
        return out
