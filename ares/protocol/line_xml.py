"""A serial instrument's ``<protocol>`` element (``ares.hardware.line_protocol``) read from and
written to XML: commands (with their own ``timeout_s``, ``retries``, ``idempotent``,
``stream``), ``<ignore pattern>`` lines and the ``<stream pattern>`` of streamed readings.

An ``identify`` command's reply pattern must refuse a garbled line (``?#%``): ``.+`` would
record line noise as the instrument's identity."""

from __future__ import annotations

import codecs
import re

from lxml import etree

from ares.hardware.line_protocol import GARBLED_PROBE, IDN_PATTERN, Command, LineProtocol
from ares.protocol.xmlsafe import fail


def _unescape(s: str) -> str:
    return codecs.decode(s, "unicode_escape")


def _escape(s: str) -> str:
    return s.encode("unicode_escape").decode("ascii")


def _pattern(path, el, what: str) -> str:
    pat = el.get("pattern") if what != "reply" else el.get("reply")
    try:
        re.compile(pat)
    except re.error as exc:
        raise fail(path, el.sourceline, f"<{el.tag}> {what} pattern '{pat}': {exc}") from None
    return pat


def _bool(s, default: bool) -> bool:
    return default if s is None else s.strip() in ("true", "1")


def protocol_from_el(path, p, kind: str, needs: tuple[str, ...]) -> LineProtocol:
    cmds = []
    for c in p.iterfind("command"):
        try:
            re.compile(c.get("reply"))
            c.get("send").format(value=0.0)
        except (re.error, ValueError, KeyError, IndexError) as exc:
            raise fail(path, c.sourceline, f"<command name='{c.get('name')}'>: {exc}") from None
        t, r = c.get("timeout_s"), c.get("retries")
        cmd = Command(c.get("name"), c.get("send"), c.get("reply"), None if t is None else float(t),
                      None if r is None else int(r), _bool(c.get("idempotent"), True), _bool(c.get("stream"), False))
        if not cmd.idempotent and cmd.retries:
            raise fail(path, c.sourceline, f"<command name='{cmd.name}' idempotent='false' retries='{cmd.retries}'>: "
                                           "a command that must not act twice is never sent again (retries must be 0)")
        if cmd.name == "identify" and re.fullmatch(cmd.reply, GARBLED_PROBE):
            raise fail(path, c.sourceline, f"<command name='identify' reply='{cmd.reply}'> accepts a garbled reply "
                                           f"('{GARBLED_PROBE}') as the instrument's identity: declare the form it "
                                           f"answers (IEEE 488.2 *IDN?: '{IDN_PATTERN}')")
        cmds.append(cmd)
    ignore = tuple(_pattern(path, e, "ignore") for e in p.iterfind("ignore"))
    st = p.find("stream")
    proto = LineProtocol(_unescape(p.get("terminator", "\\n")), _unescape(p.get("reply_terminator", "\\n")),
                         p.get("error", LineProtocol.error), tuple(cmds), _bool(p.get("echo"), False),
                         int(p.get("retries", 0)), ignore, None if st is None else _pattern(path, st, "stream"))
    missing = [n for n in needs if proto.command(n) is None]
    if missing:
        raise fail(path, p.sourceline, f"<{kind}> <protocol> declares no command named "
                                       f"{' or '.join(repr(m) for m in missing)}")
    names = [c.name for c in cmds]
    if len(set(names)) != len(names):
        raise fail(path, p.sourceline, f"<{kind}> <protocol> names a command twice")
    return proto


def protocol_to_el(el, proto: LineProtocol, _set) -> None:
    p = _set(etree.SubElement(el, "protocol"), terminator=_escape(proto.terminator),
             reply_terminator=_escape(proto.reply_terminator), error=proto.error,
             echo=True if proto.echo else None, retries=proto.retries or None)
    for c in proto.commands:
        _set(etree.SubElement(p, "command"), name=c.name, send=c.send, reply=c.reply, timeout_s=c.timeout_s,
             retries=c.retries, idempotent=None if c.idempotent else False, stream=True if c.stream else None)
    for pat in proto.ignore:
        _set(etree.SubElement(p, "ignore"), pattern=pat)
    if proto.stream is not None:
        _set(etree.SubElement(p, "stream"), pattern=proto.stream)
