"""Who a message came from, and where its reply goes: the one definition the link's services share.

A ground station is known by its MAVLink ids and the link its messages arrive over (a UDP socket and the
peer's address, or one TCP connection). Two ground stations with the same ids (every stock one defaults to
255/190) on two links are two senders: a transfer belongs to one of them, and its replies go to it alone.
"""

from __future__ import annotations

from typing import NamedTuple

Addr = tuple[str, int]
#: The serial of the link's socket and the peer's address (None on a TCP connection, which is the peer).
Link = tuple[int, Addr | None]


class Sender(NamedTuple):
    """The sender of a message: its ids and the link it came over (None: unknown, e.g. a test's direct call,
    whose replies then go to every peer)."""

    system_id: int
    component_id: int
    link: Link | None = None
