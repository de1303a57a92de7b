"""Safe XML loading: no DTD, no entities, no network -- and lxml schema errors as one
plain sentence with file and line.

Every XML file ARES reads goes through :func:`parse` then :func:`validate`. A file with a
DOCTYPE is refused outright (that is where XXE and "billion laughs" live); nothing in
an XML file is ever evaluated.
"""

from __future__ import annotations

import re
from functools import lru_cache
from importlib import resources
from pathlib import Path

from lxml import etree

from ares.errors import InputError
from ares.protocol.quantities import PRODUCES

MAX_BYTES = 16 * 1024 * 1024
MAX_DIGITS = 40  # digits of one number in an attribute or a text: more is no measurement (int() stops at 4300)
_LONG_NUMBER = re.compile(r"(?:0[xX])?[0-9A-Fa-f]*[0-9][0-9A-Fa-f]*")


def _parser() -> etree.XMLParser:
    return etree.XMLParser(
        resolve_entities=False, no_network=True, load_dtd=False, dtd_validation=False,
        huge_tree=False, remove_blank_text=False,
    )


KINDS = {"scan": "a scan file", "system": "a system file", "lot": "a lot file"}  # root element -> what it is


class WrongRoot(InputError):
    """A file whose root element is not the one expected (a scan given as a system...)."""

    def __init__(self, err: InputError, found: str, expected: str):
        super().__init__(str(err))
        self.found, self.expected = found, expected


def fail(path, line, sentence: str) -> InputError:
    """The one-sentence error every loader raises: ``file:line: sentence``."""
    where = f"{path}:{line}" if line else f"{path}"
    return InputError(f"{where}: {sentence}")


def read_bytes(path: str | Path) -> bytes:
    """A protocol file's bytes: a regular file of at most MAX_BYTES, checked before reading
    (a FIFO or /dev/zero is refused, not read)."""
    from ares.safefile import read_regular

    return read_regular(path, MAX_BYTES, "protocol file")


def parse(data: bytes, path) -> etree._ElementTree:
    """Parse bytes into a tree; refuses DOCTYPE/ENTITY declarations and non-XML."""
    if not data.strip():
        raise fail(path, 1, "file is empty; expected an XML document")
    # (the text "<!DOCTYPE" inside a comment or CDATA is no declaration: those are blanked
    # first, newlines kept for the line number; the parsed tree is checked again below)
    m = re.search(rb"<!(DOCTYPE|ENTITY)", re.sub(rb"<!--.*?-->|<!\[CDATA\[.*?\]\]>",
                                                 lambda c: re.sub(rb"[^\n]", b" ", c.group()), data, flags=re.S))
    if m:
        line = data.count(b"\n", 0, m.start()) + 1
        raise fail(path, line, f"<!{m.group(1).decode()}> declarations are not allowed "
                               "(ARES refuses DTDs and entities)")
    try:
        tree = etree.ElementTree(etree.fromstring(data, _parser()))
    except etree.XMLSyntaxError as exc:
        line = exc.lineno or (exc.position[0] if getattr(exc, "position", None) else 0)
        msg = str(exc.msg if hasattr(exc, "msg") else exc)
        msg = re.sub(r",? line \d+, column \d+$", "", msg).strip()
        if "limit exceeded" in msg.lower() or "huge" in msg.lower():
            raise fail(path, line, "an attribute or text is longer than the XML parser's limit (libxml2's "
                                   "10,000,000 characters; ARES does not lift it)") from None
        raise fail(path, line, f"not well-formed XML ({msg})") from None
    except ValueError as exc:  # e.g. unicode strings with encoding declaration
        raise fail(path, 1, f"not readable as XML ({exc})") from None
    if tree.docinfo.doctype or tree.docinfo.internalDTD is not None:
        raise fail(path, 1, "DOCTYPE declarations are not allowed (ARES refuses DTDs and entities)")
    for el in tree.iter():
        if isinstance(el, etree._Entity):
            raise fail(path, el.sourceline, f"entity reference &{el.name}; is not allowed")
        if isinstance(el.tag, str):
            _check_digits(el, path)
    return tree


def _check_digits(el, path) -> None:
    """Refuse a number of more than MAX_DIGITS digits in an attribute or a text, before
    anything converts it (``int()`` of 5000 digits is a ValueError, of 4000 a slow parse)."""
    for where, text in [*((f"<{el.tag} {k}=...>", v) for k, v in el.attrib.items()), (f"<{el.tag}>", el.text)]:
        if text and len(text) > MAX_DIGITS and re.search(r"[0-9A-Fa-f]{%d}" % (MAX_DIGITS + 1), text):
            n = max(len(m.group().removeprefix("0x").removeprefix("0X")) for m in _LONG_NUMBER.finditer(text))
            if n > MAX_DIGITS:
                raise fail(path, el.sourceline, f"{where} holds a number of {n} digits (ARES reads numbers of at "
                                                f"most {MAX_DIGITS} digits)")


@lru_cache(maxsize=None)
def schema(name: str) -> etree.XMLSchema:
    path = resources.files("ares.protocol").joinpath("schemas", f"{name}.xsd")
    text = path.read_bytes()
    return etree.XMLSchema(etree.fromstring(text, _parser(), base_url=str(path)))


# Plain-language names of the XSD types (see schemas/*.xsd).
TYPE_WORDS = {
    "xs:integer": "an integer", "xs:positiveInteger": "an integer >= 1",
    "xs:nonNegativeInteger": "an integer >= 0", "xs:double": "a number", "xs:boolean": "true or false",
    "xs:string": "text", "Name": "a name (letters, digits, '_', not starting with a digit)",
    "UInt": "a non-negative integer (decimal or 0x hex)",
    "Frames": "an integer >= 2", "Points": "an integer >= 1", "BitDepth": "an integer from 1 to 32",
    "RegBits": "8, 16 or 32", "AddrBits": "8, 16 or 32", "Access": "one of ro, wo, rw",
    "Endian": "one of big, little", "Pattern": "one of mono, RGGB, GRBG, GBRG, BGGR",
    "Interleave": "one of none, column, row, pixel", "Scene": "one of dark, flat",
    "Quantity": "one of exposure, light, temperature, analog_gain",
    "Analysis": "one of " + ", ".join(PRODUCES),  # the analyses and what they produce: one table
    "DarkMode": "one of none, matched", "Parity": "one of N, E, O", "StopBits": "1 or 2",
    "ByteSize": "7 or 8", "FrameFormat": "one of mono8, mono16le, mono16be", "ParamType": "one of int, float, bool, str, floats",
    "NumberList": "a list of finite numbers separated by spaces", "PositiveNumber": "a finite number > 0",
    "Finite": "a finite number", "QuantityPath": "a result name or dotted path (ptc.read_noise_e)", "NonNegativeNumber": "a finite number >= 0",
}

_ELEM = r"Element '(?P<el>[^']+)'(?:, attribute '(?P<attr>[^']+)')?: "


def _subject(m) -> str:
    el, attr = m.group("el"), m.group("attr")
    return f"<{el} {attr}=...>" if attr else f"<{el}>"


def _expected(text: str) -> str:
    names = [n.strip() for n in re.sub(r"[()]", "", text).split(",") if n.strip()]
    names = [re.sub(r"^\{[^}]*\}", "", n) for n in names]
    names = [n for n in names if n != "##other"]
    if not names:
        return ""
    tags = [f"<{n}>" for n in names]
    return tags[0] if len(tags) == 1 else ", ".join(tags[:-1]) + " or " + tags[-1]


def translate(message: str) -> str:
    """One lxml/libxml2 schema message -> a plain sentence."""
    msg = message.strip().rstrip(".")
    m = re.match(_ELEM + r"'(?P<val>.*)' is not a valid value of the (?:atomic|list) type '(?P<t>[^']+)'", msg, re.S)
    if m:
        words = TYPE_WORDS.get(m.group("t"), m.group("t"))
        return f"{_subject(m)} must be {words}, got '{m.group('val')}'"
    m = re.match(_ELEM + r"\[facet '(?P<f>\w+)'\] The value '(?P<val>.*?)' (?P<rest>.*)", msg, re.S)
    if m:
        f, val = m.group("f"), m.group("val")
        lim = re.search(r"\('([^']*)'\)", m.group("rest")) or re.search(r"than '([^']*)'", m.group("rest"))
        lim = lim.group(1) if lim else "?"
        if f == "enumeration":
            opts = re.search(r"set \{(.*)\}", m.group("rest"))
            opts = opts.group(1).replace("'", "") if opts else ""
            return f"{_subject(m)} must be one of {opts}, got '{val}'"
        if f == "pattern" and val.strip().lower().lstrip("+-") in ("nan", "inf", "infinity"):
            return f"{_subject(m)} must be a finite number, got '{val}'"
        word = {"minInclusive": f">= {lim}", "maxInclusive": f"<= {lim}", "minExclusive": f"> {lim}",
                "maxExclusive": f"< {lim}", "pattern": "well formed", "minLength": f"at least {lim} long"}.get(f, f)
        return f"{_subject(m)} must be {word}, got '{val}'"
    m = re.match(_ELEM + r"Missing child element\(s\)\. Expected is (?:one of )?(?P<exp>.*)", msg, re.S)
    if m:
        return f"{_subject(m)} is missing {_expected(m.group('exp'))}"
    m = re.match(_ELEM + r"This element is not expected\.?(?: Expected is (?:one of )?(?P<exp>.*))?", msg, re.S)
    if m:
        exp = _expected(m.group("exp") or "")
        return f"{_subject(m)} is not allowed here" + (f" (expected {exp})" if exp else "")
    m = re.match(_ELEM + r"The attribute '(?P<a>[^']+)' is required but missing", msg)
    if m:
        return f"{_subject(m)} needs attribute '{m.group('a')}'"
    m = re.match(_ELEM + r"The attribute '(?P<a>[^']+)' is not allowed", msg)
    if m:
        return f"<{m.group('el')}> does not take attribute '{m.group('a')}'"
    m = re.match(_ELEM + r"Character content (?:other than whitespace )?is not allowed", msg)
    if m:
        return f"{_subject(m)} must not contain text"
    m = re.match(_ELEM + r"Duplicate key-sequence \['(?P<v>[^']*)'\] in (?:unique|key) identity-constraint '(?P<c>[^']+)'", msg)
    if m:
        return f"{_subject(m)} repeats the name '{m.group('v')}' (names must be unique)"
    m = re.match(_ELEM + r"No matching global declaration available for the validation root", msg)
    if m:
        return f"<{m.group('el')}> is not a known root element"
    return msg


def validate(tree: etree._ElementTree, schema_name: str, path) -> None:
    """Validate against ``schemas/<schema_name>.xsd``; raise the first error as one sentence."""
    xsd = schema(schema_name)
    if xsd.validate(tree):
        return
    errors = list(xsd.error_log)
    first = errors[0]
    same_line = [e for e in errors if e.line == first.line]
    # libxml2 reports a facet violation, then "not a valid value of type X": prefer the type.
    typed = [e for e in same_line if re.search(r"is not a valid value of the \w+ type '([^']+)'", e.message)
             and re.search(r"type '([^']+)'", e.message).group(1) in TYPE_WORDS]
    best = typed[0] if typed else first
    raise fail(path, best.line, translate(best.message))


def load(path: str | Path, root: str, schema_name: str | None = None) -> etree._ElementTree:
    """Read, parse safely, check the root tag and validate against the schema."""
    data = read_bytes(path)
    tree = parse(data, path)
    tag = tree.getroot().tag
    if not isinstance(tag, str) or tag != root:
        shown = tag if isinstance(tag, str) else "?"
        kind = f": {KINDS[shown]} where {KINDS[root]} is expected" if shown in KINDS and root in KINDS else ""
        raise WrongRoot(fail(path, tree.getroot().sourceline, f"root element must be <{root}>, got <{shown}>{kind}"),
                        shown, root)
    validate(tree, schema_name or root, path)
    return tree
