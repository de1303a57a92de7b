"""The simulated sensor's register map (mirrors ``protocols/sim_sensor.xml``).

16-bit addresses, 16-bit registers, multi-register values big-endian. A test checks
that the XML file loads to exactly this map, so code that drives the simulator drives a
real sensor the same way: by named fields through a ``RegisterFile``.
"""

from ares.hardware.registers import Field, RegisterMap

CHIP_ID = 0xA2E5

SIM_REGISTER_MAP = RegisterMap(
    address_bits=16,
    value_bits=16,
    endian="big",
    fields=(
        Field("chip_id", 0x0000, 0, 15, access="ro", default=CHIP_ID,
              description="Chip identification (read-only)"),
        Field("streaming", 0x0001, 0, 0, default=1, minimum=0, maximum=1,
              description="1 = sensor streams frames"),
        # Exposure: 32-bit value in microseconds over registers 0x0010 (high) and 0x0011 (low).
        Field("exposure", 0x0010, 0, 31, count=2, scale=1e-6, unit="s",
              minimum=1e-6, maximum=100.0, default=10000,
              description="Integration time"),
        # Analog gain: raw/16, x1 .. x15.9375.
        Field("analog_gain", 0x0020, 0, 7, scale=1.0 / 16, unit="x",
              minimum=1.0, maximum=255 / 16, default=16,
              description="Programmable analog gain after the pixel"),
        Field("black_level", 0x0021, 0, 11, unit="DN", minimum=0, maximum=4095, default=64,
              description="Digital black-level pedestal added before the ADC clip"),
        # 0 normal, 1 dark (shutter closed: no photons), 2 ADC ramp (INL/DNL test input).
        Field("test_mode", 0x0030, 0, 1, minimum=0, maximum=2, default=0,
              description="0 normal, 1 dark (transfer gate held: no photo-charge), 2 ADC ramp"),
        # Pixel bias voltages for tuning scans (2-D maps of noise/lag vs bias).
        Field("sf_bias", 0x0050, 0, 7, scale=3.3 / 255, unit="V", minimum=0.0, maximum=3.3, default=128,
              description="Source-follower bias: pixel temporal noise rises away from 1.656 V"),
        Field("tx_low", 0x0051, 0, 7, scale=-1.0 / 255, unit="V", minimum=-1.0, maximum=0.0, default=128,
              description="Transfer-gate low level: image lag and dark current depend on it"),
    ),
)
