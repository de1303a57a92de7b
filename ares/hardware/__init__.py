"""Device interfaces (``interfaces``: ``RegisterBus``, ``FrameSource``, ``LightSource``, ``Chamber``,
``Bench``) and their backends: I2C registers (smbus2), the USB frame grabber (pyusb), GenICam
cameras (harvesters), serial instruments and their line protocols (pyserial), recorded data
(replay, EMVA 1288 descriptors, image and stack files), and the byte-level emulators of those
devices (``emulators/``). May import ``analysis`` and the base modules (``errors``, ``safefile``);
the bench a system XML describes is assembled above it, in ``ares.rig``."""
