"""Scene names: a scene's name is a folder's name, so it must be a file name that prints as it is
(:func:`check_name`, :func:`unsafe_character`); a file name in a one-line message (:func:`show_path`)."""
from __future__ import annotations

import os
from pathlib import Path

from .keys import SceneError, show_value

MAX_NAME = 100  # characters of a scene name (a file name)
MAX_NAME_BYTES = 200  # in UTF-8: results/<name> and the names a run makes beside it (up to 32 bytes longer) fit 255

_BIDI = frozenset([0x061C, 0x200E, 0x200F, *range(0x202A, 0x202F), *range(0x2066, 0x206A)])


def unsafe_character(text: str) -> str | None:
    """The first character of ``text`` that must not be in a name bridgefem prints and creates, as "U+202E (...)",
    or None: C0 and C1 control characters and DEL (a terminal acts on them: ESC and CSI sequences), the Unicode
    bidirectional-text controls (they reorder how the name is shown: ``arch\\u202egpj.exe`` shows as
    ``archexe.jpg``), line and paragraph separators (a name in a one-line message) and bytes that are not UTF-8
    (decoded as lone surrogates, which cannot be printed)."""
    for c in text:
        code = ord(c)
        if code < 0x20 or 0x7F <= code <= 0x9F:
            what = "a control character"
        elif code in _BIDI:
            what = "a bidirectional-text control, which reorders how the name is shown"
        elif code in (0x2028, 0x2029):
            what = "a line or paragraph separator"
        elif 0xD800 <= code <= 0xDFFF:
            return f"byte 0x{code & 0xFF:02X} (not UTF-8)"
        else:
            continue
        return f"U+{code:04X} ({what})"
    return None


def check_name(name: str, where: str) -> str:
    """A scene name is a file name: 1 to MAX_NAME characters and MAX_NAME_BYTES bytes, no path separator, no
    control or bidi character (:func:`unsafe_character`: it is printed and names a folder), not
    starting with "." (so neither "." nor ".." nor a hidden folder)."""
    unsafe = unsafe_character(name)
    bad = (unsafe or not name or len(name) > MAX_NAME or len(name.encode()) > MAX_NAME_BYTES or name.startswith(".")
           or "/" in name or "\\" in name or name != name.strip())
    if bad:
        held = f" (it holds {unsafe})" if unsafe else ""
        raise SceneError(f"{where} = {show_value(name)}{held}: allowed is a file name of 1 to {MAX_NAME} characters "
                         f"({MAX_NAME_BYTES} bytes in UTF-8) without /, \\, control or bidi characters or surrounding "
                         "spaces, not starting with \".\"")
    return name


def show_path(path: str | Path) -> str:
    """A file name for a one-line message: as given, or its repr (cut) when it holds control characters or is
    long."""
    text = os.fsdecode(path)
    return text if len(text) <= 200 and text.isprintable() else show_value(text, 200)
