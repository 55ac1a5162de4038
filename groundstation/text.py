"""The one owner of how the wire's words reach the operator's terminal: as text, never as markup or escapes.

Every string that comes from the vehicle or the wire (STATUSTEXT, parameter names, file names, mode names,
mission reasons, and the messages of errors that quote them) is shown by ``auv-gcs`` through this module:

- :func:`wire_text` removes the control characters (C0 with TAB, LF, CR and ESC; DEL; C1; the bidirectional
  overrides, which reorder what a terminal shows): a vehicle, or a stranger whose text the vehicle relays,
  cannot colour, move the cursor, open a hyperlink (OSC 8), set the window title or forge a line;
- :func:`plain`, :func:`lines` and :func:`labelled` make rich :class:`~rich.text.Text` of it, which rich
  never parses as markup: ``[/]`` cannot raise ``MarkupError`` (it stopped ``fly`` mid-mission before its
  HOLD), ``[link=...]`` is no hyperlink, ``[word]`` is not cut. (``rich.markup.escape`` is not used: it
  loses a backslash before ``[`` and doubles a trailing one.)

Rich renderables that format a string themselves (a :class:`~rich.progress.TextColumn`, a table cell) are
given :class:`~rich.text.Text` or ``markup=False``. ``--json`` output is JSON (control characters escaped
by the encoder) and carries the words as they came.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from rich.text import Text

#: C0 (TAB, LF, CR and ESC included), DEL, C1, and the bidirectional marks, embeddings, overrides and
#: isolates (U+200E/F, U+202A-E, U+2066-9).
CONTROL_CHARS = re.compile("[\x00-\x1f\x7f-\x9f\u200e\u200f\u202a-\u202e\u2066-\u2069]")


def wire_text(raw: object) -> str:
    """``raw`` (str, or bytes read as UTF-8 with replacement) as one line of plain text: every control
    character removed."""
    text = raw.decode("utf-8", "replace") if isinstance(raw, bytes | bytearray) else str(raw)
    return CONTROL_CHARS.sub("", text)


def plain(text: object, style: str = "") -> Text:
    """A line of ours that may quote the wire, as rich Text (never markup), its control characters (line
    breaks too: a vehicle cannot forge a line) removed."""
    return Text(wire_text(text), style=style)


def lines(texts: Iterable[object]) -> Text:
    """Several lines, each :func:`plain`."""
    return Text("\n").join(plain(t) for t in texts)


def labelled(label: str, style: str, text: object) -> Text:
    """``label`` in ``style`` (e.g. "error:" in red), a space, then ``text`` plain (see :func:`plain`)."""
    return Text.assemble(Text(label, style=style), " ", plain(text))
