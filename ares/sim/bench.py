"""The simulated bench: a register file, a frame grabber, a light source and a chamber.

Everything is driven the way a real bench is: by named register fields through a
``RegisterFile`` over ``SIM_REGISTER_MAP``. At each ``grab`` the frame source reads
exposure, analog_gain, black_level, test_mode, streaming, sf_bias and tx_low:

* sf_bias (V) scales the pixel read noise by ``1 + ((V - V0) / 0.8)**2``, V0 = default;
* tx_low (V) scales dark current by ``2**((V - V0) / 0.25)`` and image lag by
  ``2**(-(V - V0) / 0.25)`` (a deeper transfer-gate low level suppresses dark current
  and holds back more charge), V0 = default.

With ``offset_warmup_dn`` / ``offset_drift_dn_per_s`` set (``ares.sim.drift``) each frame carries
the black level's drift at its readout (its exposure's end) on the bench's clock.

Fault injection (for scan tests): ``faults={"disconnect_after_frames": N}`` raises
``DeviceGone`` when frame N+1 is requested; with ``"reconnect_after_polls": M`` the
device comes back at the M-th ``reconnect()`` (a suspender waiting for it); without it
it never does. ``{"short_frame_at": N}`` raises ``FrameError`` for the frame with
0-based index N.
"""

from __future__ import annotations

import math
import time

import numpy as np

from ares.errors import DeviceGone, FrameError, InputError, ValueOutOfRange
from ares.hardware.interfaces import Bench, Frame
from ares.hardware.registers import RegisterFile
from ares.sim import cost
from ares.sim.drift import drifts
from ares.sim.params import SensorParams
from ares.sim.ranges import TEMPERATURE_C
from ares.sim.regmap import SIM_REGISTER_MAP
from ares.sim.sensor import SimSensor
from ares.sim.strict import Pipeline, SettlingLight, SimClock

_FAULTS = ("disconnect_after_frames", "reconnect_after_polls", "short_frame_at", "frame_delay_ms",  # delay: a slow camera
           "light_tau_s", "pipeline_lag_frames")  # strict devices (ares.sim.strict): a settling LED, a lagging pipeline
_CHUNK = 1  # frames rendered per call inside grab(): one at a time -- the operating point and its plan are
#   cached across calls, so chunks saved nothing; frames now arrive as they are made (the time remaining
#   measures the render as frame time) and a 4096x3072 grab holds one frame, not 16 (400 MB)


class SimRegisterBus:
    """16-bit register file with SIM_REGISTER_MAP's defaults; read-only fields refuse writes."""

    def __init__(self, regmap=SIM_REGISTER_MAP, name: str = "sim-i2c"):
        self.name = name
        self.map = regmap
        self._bits = regmap.value_bits
        self._regs: dict[int, int] = {}
        self._ro: dict[int, str] = {}
        for f in regmap.fields:
            raw = f.default << f.lsb
            for i in reversed(range(f.count)):  # big-endian: lowest address most significant
                addr = f.address + i
                word = (raw >> (self._bits * (f.count - 1 - i))) & ((1 << self._bits) - 1)
                self._regs[addr] = self._regs.get(addr, 0) | word
                if f.access == "ro":
                    self._ro[addr] = f.name
        self.writes = 0

    def _check(self, address: int) -> int:
        if isinstance(address, bool) or not isinstance(address, (int, np.integer)):
            raise InputError(f"{self.name}: register address must be an integer, not {address!r}")
        if not 0 <= address < (1 << self.map.address_bits):
            raise ValueOutOfRange(f"{self.name}: register address 0x{address:x} is outside the address space")
        return int(address)

    def read(self, address: int) -> int:
        return self._regs.get(self._check(address), 0)

    def write(self, address: int, value: int) -> None:
        address = self._check(address)
        if address in self._ro:
            raise InputError(f"{self.name}: register 0x{address:04x} ({self._ro[address]}) is read-only")
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 0 <= value < (1 << self._bits):
            raise ValueOutOfRange(f"{self.name}: value {value!r} does not fit a {self._bits}-bit register")
        self._regs[address] = int(value)
        self.writes += 1

    def close(self) -> None:
        pass


class SimLightSource:
    """Uniform illumination; level in photons per pixel per second at the sensor. With the
    bench's ``clock`` its output is known at every time (``ares.sim.strict.SettlingLight``): a
    step at each change, or with ``tau_s`` a relaxation to the new set point with that time
    constant -- ``level_at(t)``, and ``mean_level(t0, t1)`` over a frame's exposure window;
    ``get_level`` reads the set point back, as an LED driver does; ``read_level`` is the output
    now, as the driver's monitor photodiode measures it (``readback_rtol`` relative: its tolerance)."""

    readback_rtol = 0.001  # the monitor's accuracy (relative): the readback tolerance
    readback_floor = 1.0  # ... and its offset (photons/pixel/s): a source turned off reads within it of 0

    def __init__(self, name: str = "sim-light", level: float = 0.0, clock=None, tau_s: float = 0.0):
        self.name = name
        self._clock = clock
        self._level = 0.0
        self.tau_s = float(tau_s)
        self._output = SettlingLight(clock, tau_s) if clock is not None else None
        self.set_level(level)

    def level_at(self, t: float) -> float:
        """The level at the sensor at simulated time ``t``."""
        return self._level if self._output is None else self._output.level_at(t)

    def mean_level(self, t0: float, t1: float) -> float:
        """The time-weighted level at the sensor over [t0, t1] (a frame's exposure window)."""
        return self._level if self._output is None else self._output.mean(t0, t1)

    def set_level(self, level: float) -> None:
        try:
            v = float(level)
        except (TypeError, ValueError):
            raise ValueOutOfRange(f"{self.name}: light level must be a number, not {level!r}") from None
        if not math.isfinite(v) or v < 0:
            raise ValueOutOfRange(f"{self.name}: light level {level!r} photons/pixel/s must be finite and >= 0")
        self._level = v
        if self._output is not None:
            self._output.set(v)

    def get_level(self) -> float:
        return self._level

    def read_level(self) -> float:
        """The level reaching the sensor now (the monitor's reading)."""
        return self.level_at(self._clock.now()) if self._clock is not None else self._level

    @property
    def level_tolerance(self) -> float:
        return max(self.readback_rtol * self._level, self.readback_floor)

    def settle(self, cancel=None) -> None:
        pass

    def close(self) -> None:
        pass


class SimChamber:
    """Thermal chamber with instant settling, -40 .. 125 C."""

    MIN_C, MAX_C = TEMPERATURE_C  # the simulator's physical range (ares.sim.ranges)

    def __init__(self, name: str = "sim-chamber", temperature_c: float = 25.0):
        self.name = name
        self._t = 25.0
        self.set_temperature(temperature_c)

    def set_temperature(self, celsius: float) -> None:
        try:
            v = float(celsius)
        except (TypeError, ValueError):
            raise ValueOutOfRange(f"{self.name}: temperature must be a number, not {celsius!r}") from None
        if not math.isfinite(v) or not self.MIN_C <= v <= self.MAX_C:
            raise ValueOutOfRange(f"{self.name}: temperature {celsius!r} C is outside {self.MIN_C:g} .. {self.MAX_C:g} C")
        self._t = v

    def get_temperature(self) -> float:
        return self._t

    def settle(self, cancel=None) -> None:
        pass

    def close(self) -> None:
        pass


class SimFrameSource:
    """Frame grabber over a ``SimSensor``, configured by the registers at each grab."""

    exposure_paced = False  # a frame takes its computing time, whatever the exposure

    def __init__(self, sensor: SimSensor, registers: RegisterFile, light: SimLightSource | None = None,
                 chamber: SimChamber | None = None, faults: dict | None = None, name: str = "sim grabber",
                 readout_s: float | None = None, clock: SimClock | None = None):
        """``readout_s``: paced, as a sensor streams -- a frame comes no sooner than its
        exposure + ``readout_s`` after the one before (the first: after the grab starts), or
        when computed if that is later; None: as soon as computed."""
        self.name = name
        if readout_s is not None:
            if not (math.isfinite(readout_s) and readout_s >= 0):
                raise InputError(f"{name}: the readout time must be a finite number >= 0 s, not {readout_s!r}")
            self.exposure_paced = True  # the time remaining models a frame as exposure + readout
        self.readout_s = readout_s
        self.sensor = sensor
        self.registers = registers
        self.light = light
        self.chamber = chamber
        self.monochromator = None  # ares.sim.spectral.SimMonochromator: the light's wavelength sets the QE
        self.shape = sensor.shape
        self.bit_depth = sensor.params.adc_bits
        faults = dict(faults or {})
        unknown = sorted(set(faults) - set(_FAULTS))
        if unknown:
            raise InputError(f"sim bench: unknown fault(s) {unknown} (known: {', '.join(_FAULTS)})")
        self.faults = faults
        self.frames_delivered = 0
        self._short_fired = False
        self.clock = clock if clock is not None else SimClock()  # simulated time: exposures and waits
        lag = int(faults.get("pipeline_lag_frames", 0))
        self._pipeline = Pipeline(lag) if lag > 0 else None
        self.compute_seconds = 0.0  # wall seconds spent making frames (the time remaining weighs stages by it)
        self._drifts = drifts(sensor.params)  # the black level moves on the bench's clock (ares.sim.drift)
        self._sf0 = SIM_REGISTER_MAP.field("sf_bias").to_physical(SIM_REGISTER_MAP.field("sf_bias").default)
        self._tx0 = SIM_REGISTER_MAP.field("tx_low").to_physical(SIM_REGISTER_MAP.field("tx_low").default)

    def settings(self, fields: dict | None = None) -> dict:
        """The operating point the registers and instruments define now, or would with
        ``fields`` set (register field -> physical value, ``light``, ``temperature``)."""
        fields = fields or {}
        regmap = self.registers.map

        def get(name):
            if name in fields:  # as the register would hold it
                f = regmap.field(name)
                return f.to_physical(f.to_raw(fields[name]))
            return self.registers.get(name)

        sf, tx = get("sf_bias"), get("tx_low")
        light = self.light.get_level() if self.light is not None else 0.0
        temperature = self.chamber.get_temperature() if self.chamber is not None else 25.0
        flux = fields.get("light", light) if self.light is not None else 0.0
        if self.monochromator is not None:  # the sensor's QE at the monochromator's wavelength (its truth)
            p = self.sensor.params
            flux *= p.qe_at(fields.get("wavelength", self.monochromator.get_wavelength())) / p.qe
        return dict(
            exposure_s=get("exposure"),
            analog_gain=get("analog_gain"),
            black_level_dn=get("black_level"),
            test_mode=int(get("test_mode")),
            streaming=int(get("streaming")),
            photon_flux=flux,
            temperature_c=fields.get("temperature", temperature) if self.chamber is not None else 25.0,
            read_noise_scale=1.0 + ((sf - self._sf0) / 0.8) ** 2,
            dark_current_scale=2.0 ** ((tx - self._tx0) / 0.25),
            lag_scale=2.0 ** (-(tx - self._tx0) / 0.25),
        )

    @property
    def clock_s(self) -> float:
        return self.clock.now()

    @clock_s.setter
    def clock_s(self, t: float) -> None:
        self.clock.t = float(t)

    def _exposed(self, s: dict, start: float) -> dict:
        """The next frame's settings as it is really exposed from ``start`` (the bench's clock): on a
        strict bench the pipeline's registers; and the light that fell on the sensor over the frame's
        own exposure window [start, start + exposure] -- the source's output and the monochromator's
        wavelength (the QE there), time-weighted, so a frame exposing across a change integrates part
        old, part new (``s`` itself where that is the light it was given)."""
        out = s
        if self._pipeline is not None:
            out = dict(s, **self._pipeline.frame_settings(s))
        flux = self._window_flux(start, start + out["exposure_s"])
        if flux is not None and flux != out["photon_flux"]:
            out = dict(out, photon_flux=flux)
        return out

    def _window_flux(self, t0: float, t1: float) -> float | None:
        """The photon flux (photons/pixel/s at the sensor's ``qe``) over [t0, t1]; None: no light."""
        light, mono = self.light, self.monochromator
        if light is None or not hasattr(light, "mean_level"):
            return None
        if mono is None:
            return light.mean_level(t0, t1)
        p = self.sensor.params
        if not (hasattr(mono, "moving") and mono.moving(t0, t1)):
            nm = mono.wavelength_at(t0) if hasattr(mono, "wavelength_at") else mono.get_wavelength()
            return light.mean_level(t0, t1) * (p.qe_at(nm) / p.qe)
        n = 64  # the grating moves while the frame exposes: the QE-weighted light at n midpoints
        ts = [t0 + (k + 0.5) * (t1 - t0) / n for k in range(n)]
        return sum(light.level_at(t) * p.qe_at(mono.wavelength_at(t)) for t in ts) / (n * p.qe)

    def frame_cost(self, fields: dict) -> float:
        """Relative cost of a frame with ``fields`` set (as ``settings``): the time
        remaining charges the stages to come by it (``ares.sim.cost``)."""
        s = self.settings(fields)
        mode = s.pop("test_mode")
        s.pop("streaming")
        if mode == 2:
            return cost.ramp_cost(self.sensor.patterns.adc.thresholds is not None)
        return self.sensor.frame_cost(dark=mode == 1, shot_noise=self.sensor.params.shot_noise, **s)

    def grab(self, n: int, started: float | None = None):
        """Yield ``n`` frames (ares.hardware.interfaces.Frame, uint16 data), each stamped at its
        exposure start on the bench's clock and rendered with the light over its own exposure.
        ``started``: the first frame began exposing then, not now (a streaming sensor's frame in
        flight, started as the one before was read out: ``ares.hardware.emulators.usb_device``)."""
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
            raise InputError(f"{self.name}: the number of frames must be a non-negative integer, not {n!r}")
        s = self.settings()
        if s["streaming"] != 1:
            raise FrameError(f"{self.name}: no frames arrive because the sensor is not streaming (register field 'streaming' is 0)")
        mode = s.pop("test_mode")
        s.pop("streaming")
        if mode not in (0, 1, 2):
            raise InputError(f"{self.name}: test_mode {mode} is not defined (0 normal, 1 dark, 2 ADC ramp)")
        meta = dict(s, test_mode=mode)
        left = int(n)
        last = time.perf_counter()  # (paced) when the frame before was delivered
        while left:
            k = min(left, _CHUNK, self._frames_until_fault())
            if k == 0:
                self._raise_fault()
            t0 = time.perf_counter()
            start = float(started) if started is not None and left == n else self.clock_s
            fs = self._exposed(s, start)
            if mode == 2:
                data = self.sensor.render_ramp(k)
            else:
                drift = self.sensor.offset_drift_dn(start + fs["exposure_s"]) if self._drifts else 0.0  # at readout
                data = self.sensor.render(k, dark=(mode == 1), shot_noise=self.sensor.params.shot_noise,
                                          offset_dn=drift, **fs)
            self.compute_seconds += time.perf_counter() - t0
            for frame in data:
                if self.faults.get("frame_delay_ms"):
                    time.sleep(self.faults["frame_delay_ms"] / 1000.0)
                if self.readout_s is not None:
                    due = last + s["exposure_s"] + self.readout_s
                    now = time.perf_counter()
                    if now < due:
                        time.sleep(due - now)
                    last = max(due, now)
                # Count before yielding: a consumer that stops after n frames must leave
                # the counter at n, or fault-injection points drift by one.
                index, stamp = self.frames_delivered, start
                self.frames_delivered += 1
                self.clock.advance(fs["exposure_s"])
                yield Frame(data=frame, index=index, timestamp=stamp, meta=dict(meta, **fs) if fs is not s else dict(meta))
            left -= k

    def position(self) -> dict:
        """Where the frame stream stands (``ares resume``): the frame counter the noise is
        drawn from, the delivered count and clock, and the RTS trap states carried frame
        to frame. Image lag (charge left by the last frame) is not part of it."""
        return {"frame_index": int(self.sensor.frame_index), "frames_delivered": int(self.frames_delivered),
                "clock_s": float(self.clock_s), "rts_state": self.sensor._rts_state.astype(int).tolist()}

    def seek(self, pos: dict) -> None:
        """Continue from a ``position()``: the next frames are those that followed it.
        The image lag the previous frame leaves depends only on that frame's own photo
        charge, so it is rebuilt by rendering that frame again at the settings applied
        now (the caller applies those of the stage it resumes after) and discarding it."""
        fi = int(pos["frame_index"])
        st = np.asarray(pos["rts_state"], dtype=self.sensor._rts_state.dtype)
        if st.shape != self.sensor._rts_state.shape:
            raise InputError(f"{self.name}: the recorded RTS state does not fit this sensor")
        self.sensor.reset_state()
        s = self.settings()
        if fi > 0 and s.pop("test_mode") == 0:
            s.pop("streaming")
            self.sensor.render(1, start_frame=fi - 1, **s)
        self.sensor.frame_index = fi
        self.frames_delivered = int(pos["frames_delivered"])
        self.clock_s = float(pos["clock_s"])
        self.sensor._rts_state = st

    def reconnect(self) -> None:
        """Look for the device again: ``DeviceGone`` until the ``reconnect_after_polls``-th call."""
        if "disconnect_after_frames" not in self.faults:
            return
        self._polls = getattr(self, "_polls", 0) + 1
        back = self.faults.get("reconnect_after_polls")
        if back is None or self._polls < int(back):
            raise DeviceGone(f"{self.name}: not connected")
        del self.faults["disconnect_after_frames"]  # back, and it stays

    def _frames_until_fault(self) -> int:
        lim = []
        if "disconnect_after_frames" in self.faults:
            lim.append(int(self.faults["disconnect_after_frames"]) - self.frames_delivered)
        if ("short_frame_at" in self.faults and not self._short_fired
                and self.frames_delivered <= int(self.faults["short_frame_at"])):
            lim.append(int(self.faults["short_frame_at"]) - self.frames_delivered)
        return max(0, min(lim)) if lim else 1 << 62

    def _raise_fault(self):
        d = self.faults.get("disconnect_after_frames")
        if d is not None and self.frames_delivered >= int(d):
            raise DeviceGone(f"{self.name}: device disconnected after {int(d)} frames")
        rows, cols = self.shape
        expected = rows * cols * 2
        self._short_fired = True  # the short frame is consumed; later grabs go on
        self.frames_delivered += 1
        raise FrameError(f"{self.name}: frame {self.frames_delivered - 1} arrived short "
                         f"({expected // 2} of {expected} bytes)")

    def release(self) -> None:
        """No frames for a while: drop the operating point's cached maps (~10 float32
        frames, rebuilt by the next grab -- the same frames)."""
        self.sensor.drop_plan()

    def close(self) -> None:
        self.sensor.drop_patterns()  # the sensor itself stays (bench.info["sensor"]: the truth, drawn again)


def make_sim_bench(params: SensorParams | None = None, seed: int = 0, faults: dict | None = None,
                   readout_s: float | None = None) -> Bench:
    """A complete simulated bench; ``bench.info["sensor"]`` is the SimSensor (for truth);
    ``readout_s``: frames paced as a sensor streams them (``SimFrameSource``)."""
    sensor = SimSensor(params, seed)
    bus = SimRegisterBus()
    regs = RegisterFile(SIM_REGISTER_MAP, bus)
    clock = SimClock()
    tau = float((faults or {}).get("light_tau_s", 0.0))
    light, chamber = SimLightSource(clock=clock, tau_s=tau), SimChamber()
    frames = SimFrameSource(sensor, regs, light, chamber, faults, readout_s=readout_s, clock=clock)
    bench = Bench(registers=regs, frames=frames, light=light, chamber=chamber, clock=clock,
                  info={"simulator": True, "seed": int(seed), "sensor": sensor,
                        "params": sensor.params.to_dict(), "chip_id": regs.get("chip_id")})
    if tau > 0:  # the LED relaxes on the bench's clock: a <suspend> wait for it runs on that clock too
        bench.recovery_clock = clock
    return bench
