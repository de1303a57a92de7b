"""The pyusb side of the emulated grabber (``usb_device.EmulatedGrabber``): a backend
(``usb.backend.IBackend``) whose bus holds emulated devices, so ``usb.core.find(...,
backend=EmulatedUsbBackend([grabber]))`` finds them like real ones, and the errors pyusb
raises for a device's failures (``usb_error``: errno and a timeout as libusb reports them)."""

from __future__ import annotations


def usb_error(code: int, text: str, timeout: bool = False):
    import usb.core

    cls = usb.core.USBTimeoutError if timeout else usb.core.USBError
    return cls(text, errno=code)


def _backend_base():
    import usb.backend

    return usb.backend.IBackend


class EmulatedUsbBackend(_backend_base()):
    """pyusb backend whose bus holds ``EmulatedGrabber`` devices."""

    def __init__(self, devices):
        super().__init__()
        self.devices = list(devices)

    def enumerate_devices(self):
        for i, d in enumerate(self.devices):
            if d.present():
                yield (i, d)

    def get_device_descriptor(self, dev):
        i, d = dev
        return d.device_descriptor(i + 1)

    def get_configuration_descriptor(self, dev, config):
        return dev[1].config_descriptor()

    def get_interface_descriptor(self, dev, intf, alt, config):
        return dev[1].interface_descriptor()

    def get_endpoint_descriptor(self, dev, ep, intf, alt, config):
        return dev[1].endpoint_descriptor()

    def open_device(self, dev):
        dev[1]._gone()
        return dev[1]

    def close_device(self, dev_handle):
        dev_handle.handles_closed += 1

    def set_configuration(self, dev_handle, config_value):
        dev_handle._gone()
        dev_handle.configuration = config_value

    def get_configuration(self, dev_handle):
        dev_handle._gone()
        return dev_handle.configuration or 1

    def set_interface_altsetting(self, dev_handle, intf, altsetting):
        pass

    def claim_interface(self, dev_handle, intf):
        dev_handle._gone()

    def release_interface(self, dev_handle, intf):
        pass

    def bulk_read(self, dev_handle, ep, intf, buff, timeout):
        part = dev_handle.bulk_read(ep, len(buff), timeout)
        n = len(part)
        memoryview(buff).cast("B")[:n] = part
        return n

    def ctrl_transfer(self, dev_handle, bmRequestType, bRequest, wValue, wIndex, data, timeout):
        out = dev_handle.control(bmRequestType, bRequest, wValue, wIndex, data)
        if bmRequestType & 0x80:  # IN: copy into the caller's buffer, return the count
            n = min(len(out), len(data))
            memoryview(data).cast("B")[:n] = out[:n]
            return n
        return out

    def clear_halt(self, dev_handle, ep):
        dev_handle.clear_halt(ep)

    def reset_device(self, dev_handle):
        pass

    def is_kernel_driver_active(self, dev_handle, intf):
        return False

    def detach_kernel_driver(self, dev_handle, intf):
        pass

    def attach_kernel_driver(self, dev_handle, intf):
        pass
