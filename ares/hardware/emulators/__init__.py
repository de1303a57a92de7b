"""Emulated devices that speak the wire: a USB grabber streaming a frame source in the
declared wire format (``usb_device``) behind a pyusb backend (``usb_backend``), an I2C device
taking smbus2 ``i2c_msg`` transactions (``i2c_device``), serial instruments behind the
pyserial URL ``aresemu://NAME`` (``serial_device``, ``protocol_aresemu``). Each injects faults
on request. The simulated bench wired through them is ``ares.rig.wire``."""
