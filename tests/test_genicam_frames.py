"""GenICam frames (issue 36, findings 5, 8, 9) on a GenTL-free image acquirer whose buffers
carry what harvesters' ``Component2DImage`` holds: the pixel format's name and the data
expanded by harvesters' own PFNC table (``harvesters.util.pfnc.Dictionary``). Packed
(GigE Vision Mono12Packed) and Bayer (BayerRG12) buffers become the sensor's codes; a Bayer
mosaic other than the declared <cfa> and colour formats are refused; the fetch timeout
follows the frame time; the camera's identity and link counts reach the run record.
Before, Mono12Packed and Bayer were refused and the fetch timeout was the XML's alone."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ares.errors import FrameError, HardwareError
from ares.hardware.genicam import GenICamCamera, GenICamFrameSource

SHAPE = (4, 6)


def _mono12packed(codes: np.ndarray) -> np.ndarray:
    """GigE Vision Mono12Packed: pixels a, b -> a[11:4], b[3:0]<<4 | a[3:0], b[11:4]."""
    a, b = codes.ravel()[0::2].astype(np.uint16), codes.ravel()[1::2].astype(np.uint16)
    out = np.empty(a.size * 3, np.uint8)
    out[0::3], out[1::3], out[2::3] = a >> 4, ((b & 0xF) << 4) | (a & 0xF), b >> 4
    return out


def _buffer(fmt: str, raw: np.ndarray, fid: int):
    from harvesters.util.pfnc import Dictionary

    comp = SimpleNamespace(data_format=fmt, height=SHAPE[0], width=SHAPE[1],
                           data=Dictionary.get_proxy(symbolic=fmt).expand(raw))  # harvesters' own expansion
    return SimpleNamespace(module=SimpleNamespace(frame_id=fid), payload=SimpleNamespace(components=[comp]),
                           queue=lambda: None)


class Acquirer:
    def __init__(self, fmt: str, raws: list, timeout_after: int | None = None):
        self.fmt, self.raws, self.timeout_after, self.timeouts = fmt, raws, timeout_after, []
        self.n = 0

    def start(self):
        pass

    def stop(self):
        pass

    def fetch(self, timeout):
        self.timeouts.append(timeout)
        if self.timeout_after is not None and self.n >= self.timeout_after:
            raise type("TimeoutException", (Exception,), {})("no buffer")
        raw = self.raws[self.n % len(self.raws)]
        self.n += 1
        return _buffer(self.fmt, raw, self.n)


def _source(fmt: str, raws: list, cfa: str = "mono", **kw) -> GenICamFrameSource:
    cam = GenICamCamera.__new__(GenICamCamera)  # without a GenTL producer
    cam.cfg, cam.name = SimpleNamespace(timeout_ms=3000, features=()), "GenICam camera 'cam'"
    cam.ia = Acquirer(fmt, raws, **kw)
    cam.nodes = SimpleNamespace(DeviceVendorName=SimpleNamespace(value="Acme"),
                                DeviceModelName=SimpleNamespace(value="GC-1"),
                                DeviceSerialNumber=SimpleNamespace(value="SN1234"))
    return GenICamFrameSource(cam, SHAPE, 12, cfa)


def test_mono12packed_through_harvesters_expansion_gives_the_codes():
    codes = np.random.default_rng(1).integers(0, 4096, SHAPE, dtype=np.uint16)
    src = _source("Mono12Packed", [_mono12packed(codes)])
    frame = next(iter(src.grab(1)))
    assert frame.data.dtype == np.uint16 and np.array_equal(frame.data, codes)


def test_bayer_rg12_is_the_raw_mosaic_of_a_declared_rggb_sensor():
    codes = np.random.default_rng(2).integers(0, 4096, SHAPE, dtype=np.uint16)
    raw = codes.astype("<u2").view(np.uint8)  # BayerRG12: 12 bits in a little-endian 16-bit container
    frames = list(_source("BayerRG12", [raw], cfa="RGGB").grab(2))
    assert all(np.array_equal(f.data, codes) for f in frames)
    with pytest.raises(FrameError, match=r"pixel format BayerRG12 is a RGGB mosaic but the system XML declares "
                                         r"<cfa pattern='GBRG'>"):
        next(iter(_source("BayerRG12", [raw], cfa="GBRG").grab(1)))
    rgb = np.zeros(SHAPE[0] * SHAPE[1] * 3, np.uint8)
    with pytest.raises(FrameError, match=r"pixel format RGB8 is not raw sensor data"):
        next(iter(_source("RGB8", [rgb]).grab(1)))


def test_fetch_timeout_follows_the_frame_time_and_is_counted():
    codes = np.zeros(SHAPE, np.uint16)
    src = _source("Mono12Packed", [_mono12packed(codes)], timeout_after=1)
    src.set_frame_time(20.5)  # a 20 s exposure + readout + margin (ares.scan.apply)
    with pytest.raises(HardwareError, match=r"no frame within 20500 ms \(timeout\) at frame 1"):
        list(src.grab(2))
    assert src.camera.ia.timeouts == [20.5, 20.5]
    src.set_frame_time(0.01)  # shorter than the XML's: the XML's timeout_ms
    with pytest.raises(HardwareError, match=r"within 3000 ms"):
        list(src.grab(1))
    assert src.link_counters() == {"frames": 1, "dropped_frames": 0, "timeouts": 2}
    assert src.identity() == {"interface": "GenICam", "vendor": "Acme", "model": "GC-1", "serial": "SN1234"}


def test_an_unplugged_camera_is_opened_again_by_the_recovery(tmp_path, monkeypatch):
    """Finding 8 ("no reconnect"): the producer lists no camera while it is away (DeviceGone,
    so the recovery waits and tries again); once back, the same camera by serial number is
    selected and its <set> features are written again."""
    import harvesters.core

    from ares.errors import DeviceGone
    from ares.hardware.interfaces import Bench

    listed = {"cams": [SimpleNamespace(id_="dev0", serial_number="SN1234")]}
    opened = []

    class FakeHarvester:
        def add_file(self, path):
            pass

        def update(self):
            self.device_info_list = list(listed["cams"])

        def create(self, i):
            nodes = SimpleNamespace(PixelFormat=SimpleNamespace(value="Mono8", symbolics=("Mono8", "Mono12Packed")))
            opened.append(nodes)
            return SimpleNamespace(remote_device=SimpleNamespace(node_map=nodes), destroy=lambda: None)

        def reset(self):
            pass

    monkeypatch.setattr(harvesters.core, "Harvester", FakeHarvester)
    cti = tmp_path / "producer.cti"
    cti.write_bytes(b"")
    cfg = SimpleNamespace(name="cam", cti=str(cti), device="SN1234", timeout_ms=3000, features=(),
                          sets=(("PixelFormat", "Mono12Packed"),))
    cam = GenICamCamera(cfg)
    src = GenICamFrameSource(cam, SHAPE, 12)
    bench = Bench(SimpleNamespace(bus=None), src)
    listed["cams"] = []  # unplugged
    with pytest.raises(DeviceGone, match=r"GenICam camera 'cam': the GenTL producer lists no camera"):
        bench.reconnect("frames")
    listed["cams"] = [SimpleNamespace(id_="dev1", serial_number="SN9"), SimpleNamespace(id_="dev0",
                                                                                        serial_number="SN1234")]
    bench.reconnect("frames")
    assert len(opened) == 2 and opened[-1].PixelFormat.value == "Mono12Packed" and cam.nodes is opened[-1]


def test_device_timestamps_are_recorded_and_a_timeout_is_a_lost_frame():
    """Issue 49: the camera's own time stamp (GenTL ``timestamp_ns``) rides with each frame
    beside the host's arrival time; a fetch that times out is a frame lost (kind "timeout"),
    which a scan re-grabs under ``on_loss="regrab"`` or a ``<suspend>`` device condition."""
    from ares.errors import FrameLost

    codes = np.zeros(SHAPE, np.uint16)
    src = _source("Mono12Packed", [_mono12packed(codes)] * 2, timeout_after=2)
    bufs = src.camera.ia
    stamps = iter((1_500_000_000, 1_533_333_333))
    real = bufs.fetch

    def fetch(timeout):
        b = real(timeout)
        b.timestamp_ns = next(stamps)
        return b

    bufs.fetch = fetch
    frames = list(src.grab(2))
    assert [f.meta["device_timestamp_s"] for f in frames] == [1.5, 1.533333333]
    with pytest.raises(FrameLost) as info:
        list(src.grab(1))
    assert info.value.kind == "timeout"
