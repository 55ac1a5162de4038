"""The mission protocol's client side over a :class:`~groundstation.link.Link`: upload, download and clear a
plan (the mission, the fence, or both in one transfer of type MAV_MISSION_TYPE_ALL)."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink

from auv_common.mission_items import MissionItem as Item  # the one mission item encoding (shared)
from groundstation.link import Link, LinkError
from groundstation.messages import MISSION_RESULT_NAMES, Msg

#: Answers of the mission protocol: ones already waiting when a transfer begins are stale.
MISSION_REPLIES = (
    "MISSION_ACK",
    "MISSION_COUNT",
    "MISSION_ITEM_INT",
    "MISSION_REQUEST_INT",
    "MISSION_REQUEST",
)


@dataclass(frozen=True)
class TransferResult:
    """Outcome of a mission transfer: MAV_MISSION result code, its name, time taken, resends, and on a
    refusal the vehicle's reason (its STATUSTEXT; "" if it sent none)."""

    ok: bool
    result: int
    result_name: str
    elapsed_s: float
    resends: int
    reason: str = ""


class MissionClient:
    """Mission transfers with the vehicle the link talks to (its ``target``)."""

    def __init__(self, link: Link) -> None:
        self.link = link

    def upload(
        self,
        items: list[Item],
        mission_type: int = mavlink.MAV_MISSION_TYPE_MISSION,
        *,
        progress: Callable[[int, int], None] | None = None,
        resend_s: float = 0.4,
        timeout_s: float = 8.0,
    ) -> TransferResult:
        """Upload a plan; returns the vehicle's MISSION_ACK result (or a timeout, result -1).

        The vehicle re-requests a missing item every 250 ms; to recover faster from a lost packet the
        client also resends its last message when no answer came within a few measured round trips
        (at least 30 ms, at most ``resend_s``): a lost item is then delivered, and a lost request is
        answered by the vehicle with a fresh request for the item it needs.
        """
        link = self.link
        link.drop_stale(MISSION_REPLIES)
        t0 = time.monotonic()
        n = len(items)
        ts, tc = link.target
        count_msg = mavlink.MAVLink_mission_count_message(ts, tc, n, mission_type)
        link.send(count_msg)
        resends = 0
        got_request = False
        last_sent: Msg = count_msg
        sent_last_item = n == 0
        last_tx = last_progress = time.monotonic()
        done = 0
        rtt_s = resend_s / 4.0
        wait_s = resend_s
        while True:
            now = time.monotonic()
            if now - last_progress > timeout_s:
                return TransferResult(
                    False, -1, "TIMEOUT", now - t0, resends, link.signing_note().strip(" ()")
                )
            m = link.recv(max(0.0, min(wait_s - (now - last_tx), 0.1)))
            now = time.monotonic()
            if m is None:
                if now - last_tx >= wait_s:
                    wait_s = min(resend_s, wait_s * 2.0)  # back off while nothing comes back
                    link.send(last_sent if got_request else count_msg)
                    resends += 1
                    last_tx = now
                continue
            if not (link.from_vehicle(m) and link.to_us(m)):
                continue
            kind = m.get_type()
            if kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST") and m.mission_type == mission_type:
                if not 0 <= m.seq < n:
                    continue
                got_request = True
                it = items[m.seq]
                last_sent = mavlink.MAVLink_mission_item_int_message(
                    ts, tc, m.seq, it.frame, it.command, 0, it.autocontinue,
                    it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z, mission_type,
                )  # fmt: skip
                if m.seq == done and done > 0:  # answer to our last item: a round-trip sample
                    rtt_s = 0.8 * rtt_s + 0.2 * (now - last_tx)
                link.send(last_sent)
                last_tx = now
                wait_s = min(resend_s, max(0.03, 4.0 * rtt_s))
                if m.seq >= done:
                    done = m.seq + 1
                    last_progress = now
                    if progress is not None:
                        progress(m.seq, n)
                if m.seq == n - 1:
                    sent_last_item = True
            elif kind == "MISSION_ACK" and m.mission_type == mission_type:
                if m.type == mavlink.MAV_MISSION_ACCEPTED and not sent_last_item:
                    continue  # a stale ACK of an earlier transfer
                if progress is not None and m.type == mavlink.MAV_MISSION_ACCEPTED:
                    progress(n, n)
                name = MISSION_RESULT_NAMES.get(m.type, str(m.type))
                elapsed = time.monotonic() - t0
                ok = m.type == mavlink.MAV_MISSION_ACCEPTED
                reason = "" if ok else link.reason_after(t0, time.monotonic())
                return TransferResult(ok, int(m.type), name, elapsed, resends, reason)

    def download(
        self,
        mission_type: int = mavlink.MAV_MISSION_TYPE_MISSION,
        *,
        resend_s: float = 0.5,
        retries: int = 10,
    ) -> list[Item]:
        """Download a plan (MISSION_REQUEST_LIST, then MISSION_REQUEST_INT per item, then MISSION_ACK)."""
        link = self.link
        link.drop_stale(MISSION_REPLIES)
        ts, tc = link.target
        req = mavlink.MAVLink_mission_request_list_message(ts, tc, mission_type)

        def is_count(m: Msg) -> bool:
            return bool(m.mission_type == mission_type)

        count_msg = self._request_reply(req, "MISSION_COUNT", is_count, resend_s, retries)
        if count_msg.get_type() == "MISSION_ACK":
            raise LinkError(f"download refused: {MISSION_RESULT_NAMES.get(count_msg.type, count_msg.type)}")
        items: list[Item] = []
        for seq in range(count_msg.count):
            r = mavlink.MAVLink_mission_request_int_message(ts, tc, seq, mission_type)

            def is_item(m: Msg, s: int = seq) -> bool:
                return bool(m.seq == s and m.mission_type == mission_type)

            m = self._request_reply(r, "MISSION_ITEM_INT", is_item, resend_s, retries)
            if m.get_type() == "MISSION_ACK":
                raise LinkError(f"download failed: {MISSION_RESULT_NAMES.get(m.type, m.type)}")
            items.append(
                Item(
                    m.frame, m.command, m.param1, m.param2, m.param3, m.param4, m.x, m.y, m.z, m.autocontinue
                )
            )
        link.send(mavlink.MAVLink_mission_ack_message(ts, tc, mavlink.MAV_MISSION_ACCEPTED, mission_type))
        return items

    def clear(
        self, mission_type: int = mavlink.MAV_MISSION_TYPE_MISSION, *, resend_s: float = 0.5
    ) -> TransferResult:
        """MISSION_CLEAR_ALL with retries; returns the vehicle's ACK."""
        link = self.link
        link.drop_stale(MISSION_REPLIES)
        t0 = time.monotonic()
        ts, tc = link.target
        req = mavlink.MAVLink_mission_clear_all_message(ts, tc, mission_type)

        def is_ack(m: Msg) -> bool:
            return bool(m.mission_type == mission_type)

        m = self._request_reply(req, "MISSION_ACK", is_ack, resend_s, 10)
        name = MISSION_RESULT_NAMES.get(m.type, str(m.type))
        elapsed = time.monotonic() - t0
        ok = m.type == mavlink.MAV_MISSION_ACCEPTED
        return TransferResult(
            ok, int(m.type), name, elapsed, 0, "" if ok else link.reason_after(t0, time.monotonic())
        )

    def _request_reply(
        self, req: Msg, kind: str, match: Callable[[Msg], bool], resend_s: float, retries: int
    ) -> Msg:
        """Send ``req`` until a ``kind`` message matching ``match`` (or a MISSION_ACK error) arrives."""
        link = self.link
        for _ in range(retries):
            link.send(req)
            deadline = time.monotonic() + resend_s
            while (left := deadline - time.monotonic()) > 0:
                m = link.recv(left)
                if m is None or not (link.from_vehicle(m) and link.to_us(m)):
                    continue
                if m.get_type() == kind and match(m):
                    return m
                if m.get_type() == "MISSION_ACK" and kind != "MISSION_ACK" and m.type != 0:
                    return m
        raise LinkError(f"no {kind} from the vehicle after {retries} tries{link.signing_note()}")
