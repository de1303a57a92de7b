"""The bench a system XML describes, assembled: real I2C/USB/serial/GenICam backends, the
simulated sensor directly or behind emulated wires, recorded data. Imports ``hardware``,
``sim``, ``analysis`` and the base modules; nothing above."""
