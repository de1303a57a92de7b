"""Typed GenICam features (issue 36, finding 8) on a GenTL-free model of the node map (the
same duck-typed interface the genicam wheel's nodes offer: value, min, max, inc, symbolics):
a camera with ExposureTime (Float, us), Gain (Float, dB, negative), AcquisitionFrameRate
(Float), BinningHorizontal (Integer, increment), PixelFormat (Enumeration) and ReverseX
(Boolean). Values are checked before they are set; floats and negatives arrive intact."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from ares.errors import ValueOutOfRange
from ares.hardware.genicam import FeatureBus, GenICamCamera, feature_map
from ares.hardware.genicam_features import FeatureFile
from ares.protocol.devices import Feature


class Node:
    def __init__(self, value, min=None, max=None, inc=None, symbolics=None):
        self.value, self.min, self.max, self._inc = value, min, max, inc
        if symbolics is not None:
            self.symbolics = tuple(symbolics)
        self.writes = []

    @property
    def inc(self):
        if self._inc is None:
            raise AttributeError("no increment")  # GenApi raises for a Float without one
        return self._inc

    def has_inc(self):
        return self._inc is not None

    def __setattr__(self, k, v):
        if k == "value" and "writes" in self.__dict__:
            self.writes.append(v)
        object.__setattr__(self, k, v)


def _camera():
    nodes = SimpleNamespace(
        ExposureTime=Node(10000.0, 10.0, 2e7), Gain=Node(0.0, -6.0, 24.0), AcquisitionFrameRate=Node(30.0, 1.0, 60.0),
        BinningHorizontal=Node(1, 1, 4, 1), Width=Node(640, 16, 1280, 16),
        PixelFormat=Node("Mono8", symbolics=("Mono8", "Mono12Packed", "BayerRG12")), ReverseX=Node(False))
    features = (Feature("exposure", "ExposureTime", 1e-6, "s"), Feature("analog_gain", "Gain", 1.0, "dB", -6, 24),
                Feature("frame_rate", "AcquisitionFrameRate", 1.0, "Hz"), Feature("binning", "BinningHorizontal"))
    cam = GenICamCamera.__new__(GenICamCamera)  # the node map without a GenTL producer
    cam.cfg, cam.name, cam.nodes = SimpleNamespace(features=features), "GenICam camera 'cam'", nodes
    return cam, FeatureFile(feature_map(cam.cfg), FeatureBus(cam))


def test_floats_and_negative_values_arrive_intact():
    cam, regs = _camera()
    regs.set("frame_rate", 29.97)
    regs.set("analog_gain", -3.0)
    regs.set("exposure", 0.0123456)
    assert cam.nodes.AcquisitionFrameRate.writes == [29.97] and cam.nodes.Gain.writes == [-3.0]
    assert cam.nodes.ExposureTime.value == pytest.approx(12345.6)
    assert regs.get("analog_gain") == -3.0 and regs.get("exposure") == pytest.approx(0.0123456)
    assert regs.get("frame_rate") == 29.97


@pytest.mark.parametrize("node,value,sentence", [
    ("Gain", -7, r"feature Gain: -7 is outside -6 \.\. 24"),
    ("ExposureTime", 3e7, r"feature ExposureTime: 3e\+07 is outside 10 \.\. 2e\+07"),
    ("BinningHorizontal", 2.5, r"feature BinningHorizontal is an Integer: 2.5 is not a whole number"),
    ("Width", 650, r"feature Width: 650 is not on its increment 16 from 16 \(nearest: 640 or 656\)"),
    ("PixelFormat", "Mono10", r"feature PixelFormat is an Enumeration: 'Mono10' is not one of Mono8, "
                              r"Mono12Packed, BayerRG12"),
    ("ReverseX", "maybe", r"feature ReverseX is a Boolean: 'maybe' is not true/false"),
    ("Gain", "loud", r"feature Gain is a Float: 'loud' is not a number"),
])
def test_a_value_the_node_cannot_take_is_refused_before_anything_is_written(node, value, sentence):
    cam, _ = _camera()
    with pytest.raises(ValueOutOfRange, match=r"^GenICam camera 'cam': " + sentence):
        cam.write(node, value)
    assert getattr(cam.nodes, node).writes == []


def test_each_type_takes_its_values():
    cam, regs = _camera()
    for node, value, stored in (("PixelFormat", "BayerRG12", "BayerRG12"), ("ReverseX", "true", True),
                                ("ReverseX", 0, False), ("Width", "1280", 1280), ("BinningHorizontal", 2.0, 2)):
        cam.write(node, value)
        got = getattr(cam.nodes, node).value
        assert got == stored and type(got) is type(stored)
    with pytest.raises(ValueOutOfRange, match=r"register field 'analog_gain': -8 dB is below its minimum -6"):
        regs.set("analog_gain", -8)  # the XML's limit, before the camera's


def test_a_node_with_one_limit_names_the_open_range():
    cam, _ = _camera()
    cam.nodes.Gain.max = None
    with pytest.raises(ValueOutOfRange, match=r"feature Gain: -7 is outside >= -6$"):
        cam.write("Gain", -7)
    cam.write("Gain", 100.0)
    assert cam.nodes.Gain.value == 100.0
