"""groundstation.text: the wire's words as text, never markup or escapes (issue 21 row 6)."""

from __future__ import annotations

import io

from hypothesis import given
from hypothesis import strategies as st
from rich.console import Console

from groundstation.text import labelled, lines, plain, wire_text

CONTROL_RUN = "".join(chr(c) for c in [*range(0, 32), 0x7F, *range(0x80, 0xA0)])[:50]


def render(text: object, *, terminal: bool) -> str:
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=terminal, width=200, soft_wrap=True, color_system="truecolor")
    console.print(text)
    return buf.getvalue()


def test_a_50_character_run_of_control_bytes_is_removed() -> None:
    assert len(CONTROL_RUN) == 50
    assert wire_text(f"a{CONTROL_RUN}b") == "ab"
    assert wire_text("x\u202eevil\u2066y\u200f") == "xevily"  # bidirectional overrides reorder a line
    assert wire_text(b"\x1b[31mred\xff") == "[31mred\ufffd"


def test_markup_and_escapes_are_shown_as_text_on_a_terminal() -> None:
    for s in (
        "[/]",
        "[link=http://x]x[/link]",
        "[bold]word[/bold]",
        "a\\",
        "\\[b]",
        "\x1b]8;;http://x\x1b\\",
    ):
        out = render(labelled("vehicle:", "dim", s), terminal=True)
        assert wire_text(s) in out and "\x1b]8;" not in out, (s, out)
        assert render(plain(s), terminal=False) == wire_text(s) + "\n"


def test_lines_cannot_be_forged_by_a_line_break_in_the_wire() -> None:
    assert render(lines(["a\nforged", "b"]), terminal=False) == "aforged\nb\n"


@given(st.text(max_size=40))
def test_any_string_prints_as_its_text_without_control_characters(s: str) -> None:
    out = render(plain(s), terminal=False)
    assert out == wire_text(s) + "\n"
    assert not any(ord(c) < 32 and c != "\n" for c in out)
