"""Safe, bounded XML parsing and strict number reading for untrusted descriptions.

`parse_bounded` parses with defusedxml (a DTD, an entity declaration or an external reference is
refused outright, so entity expansion bombs and external entities never run) and counts elements
and nesting depth while parsing, so a huge or deeply nested document is stopped as soon as it
passes a cap instead of after it has been built in memory.

`read_numbers` accepts only plain ASCII decimal numbers (`-1.5e-3`, `.5`, `7`): Python's `float`
also reads `1_000`, `nan`, `infinity` and non-ASCII digits (`١`), which the native C++ parser
reads differently or not at all, so the two parsers could disagree about what a file says.
"""

from __future__ import annotations

import math
import re
from xml.etree.ElementTree import Element, TreeBuilder

from defusedxml import DefusedXmlException
from defusedxml.ElementTree import DefusedXMLParser, ParseError

from service.errors import InvalidModel

_NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_CHUNK = 1 << 16  # characters fed to the parser at a time
_SHOWN = 64  # longest name quoted in a message


def shown(name: str | None) -> str:
    """A name as quoted in messages: at most 64 printable characters (never a huge echo)."""
    if name is None:
        return ""
    out = name if name.isprintable() else name.encode("ascii", "backslashreplace").decode()
    return out if len(out) <= _SHOWN else out[:_SHOWN] + "…"


class XmlOverCaps(Exception):
    """An XML document with more elements or deeper nesting than its caps allow; the message
    says which cap and its value."""

    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.message = message


class _CappedBuilder(TreeBuilder):
    """A tree builder that refuses more than `max_elements` elements or nesting `max_depth`."""

    def __init__(self, max_elements: int, max_depth: int) -> None:
        super().__init__()
        self.max_elements, self.max_depth = max_elements, max_depth
        self.count = self.depth = 0

    def start(self, tag: str, attrs: dict[str, str]) -> Element:
        self.count += 1
        self.depth += 1
        if self.count > self.max_elements:
            raise XmlOverCaps(
                f"the description has more than {self.max_elements} XML elements "
                "(limit ROBODYN_MAX_XML_ELEMENTS)"
            )
        if self.depth > self.max_depth:
            raise XmlOverCaps(
                f"the XML is nested deeper than {self.max_depth} levels "
                "(limit ROBODYN_MAX_XML_DEPTH)"
            )
        return super().start(tag, attrs)

    def end(self, tag: str) -> Element:
        self.depth -= 1
        return super().end(tag)


def parse_bounded(text: str, max_elements: int, max_depth: int) -> Element:
    """Parse XML text with no DTD, entities or external references, within the caps.

    Raises `InvalidModel` with a reason; never echoes the text.
    """
    builder = _CappedBuilder(max_elements, max_depth)
    parser = DefusedXMLParser(
        target=builder, forbid_dtd=True, forbid_entities=True, forbid_external=True
    )
    try:
        for start in range(0, len(text), _CHUNK):
            parser.feed(text[start : start + _CHUNK])
        root: Element = parser.close()
    except XmlOverCaps as exc:
        raise InvalidModel(exc.message) from None
    except DefusedXmlException:
        raise InvalidModel(
            "the XML has a DTD, entity or external reference; these are refused"
        ) from None
    except ParseError as exc:
        raise InvalidModel(f"the text is not well-formed XML ({_position(exc)})") from None
    except (ValueError, UnicodeError):  # e.g. lone surrogates that cannot be encoded
        raise InvalidModel(
            "the text is not well-formed XML (it has characters that cannot be encoded as UTF-8)"
        ) from None
    return root


NAME_ATTRIBUTES = ("name", "model")  # <robot name>, <link name>, <joint name>, <mujoco model>, ...


def check_name_lengths(root: Element, max_length: int) -> None:
    """Refuse any element whose name (`name`, or MJCF's `model`) is longer than `max_length`
    characters: names are echoed in every answer that lists joints or frames."""
    for el in root.iter():
        for attr in NAME_ATTRIBUTES:
            value = el.get(attr)
            if value is not None and len(value) > max_length:
                raise InvalidModel(
                    f"<{shown(str(el.tag))}> {attr} '{shown(value)}' is {len(value)} characters "
                    f"long; the limit is {max_length} (ROBODYN_MAX_NAME_LENGTH)"
                )


def _position(exc: ParseError) -> str:
    # expat's own text: "mismatched tag: line 1, column 30"; keep it short.
    return str(exc).split("\n")[0][:120]


def read_numbers(raw: str | None, count: int, what: str, default: str | None = None) -> list[float]:
    """Exactly `count` finite plain decimal numbers from an attribute value."""
    raw = raw if raw is not None else default
    if raw is None:
        raise InvalidModel(f"{what} is missing")
    parts = raw.split()
    if len(parts) != count:
        raise InvalidModel(
            f"{what} must have {count} number{'s' if count > 1 else ''}, found {len(parts)} values"
        )
    values = []
    for part in parts:
        if not _NUMBER.fullmatch(part):
            if part.lower().lstrip("+-") in ("nan", "inf", "infinity"):
                raise InvalidModel(f"{what} must be finite")
            raise InvalidModel(f"{what} is not a number (plain decimals only, e.g. -1.5e-3)")
        value = float(part)
        if not math.isfinite(value):
            raise InvalidModel(f"{what} must be finite")
        values.append(value)
    return values
