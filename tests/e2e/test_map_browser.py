"""`auv-gcs map` in a real browser (headless Chromium through Selenium).

- live: `auv-hil` + `auv-onboard` + `auv-gcs` as real processes on 127.0.0.1, a mission of two goals and an
  obstacle uploaded, armed and started by `auv-gcs`, then `auv-gcs map`: the page loads without a console
  error, shows RUNNING, goal 1 of 2, the goals (with their heading arrows) and the obstacle at scale, and the
  vehicle marker moves with the vehicle's LOCAL_POSITION_NED (the very samples the map's tlog recorded);
- replay: `auv-gcs map --tlog` of that flight's tlog: the slider and the play button move the marker;
- the planned path: drawn from the vehicle's path file, through the real link thread, server and page with
  a scripted client (and, once `MavClient.read_file` exists, in the live flight too);
- a plan as QGC uploads it (a home placeholder, global waypoints) with a scripted client: drawn about the
  vehicle's GPS_GLOBAL_ORIGIN, "goal 1 of 2" while the vehicle flies goal 1 (MISSION_CURRENT.seq 1);
- no update for 3 s (the server pushes none): the link badge says so;
- a port already in use is one line, exit 2.

Chromium and chromedriver are Debian's (/usr/bin; `make venv` installs them): missing, the tests fail (no
skip). ``AUV_MAP_SCREENSHOT=1`` writes docs/map.png (1200x800) from the live flight.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import os
import re
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import pytest
from aiohttp import web
from pymavlink.dialects.v20 import common as mavlink
from selenium import webdriver
from selenium.webdriver import ActionChains
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.actions.wheel_input import ScrollOrigin

from groundstation.map.server import LiveLink, LiveSource, make_app
from groundstation.map.state import PLANNED_PATH_FILE, MapModel
from groundstation.mavclient import Item, LinkError, MavClient
from groundstation.mission_files import goal_item, home_item, obstacle_item
from groundstation.tlog import read_tlog
from hil_sim.scenario import free_port, free_udp_port
from tests.e2e.procs import bench_cmd, onboard_cmd, processes, start_vehicle, upload_arm_start

pytestmark = pytest.mark.e2e

CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")
REPO = Path(__file__).resolve().parents[2]
SCREENSHOT = REPO / "docs" / "map.png"
START = (-13.0, 0.0, 1.0, 0.0)  # x, y, depth, yaw_deg: heading north towards goal 1
GOALS = [(15.0, 0.0, 1.0, 0.0), (25.0, 15.0, 1.5, 90.0)]
OBSTACLE = (2.0, 5.0, 2.0)  # x, y, radius (m): beside the first leg
MISSION_YAML = (
    "goals:\n"
    + "".join(f"  - {{x_m: {x}, y_m: {y}, depth_m: {d}, yaw_deg: {yaw}}}\n" for x, y, d, yaw in GOALS)
    + f"obstacles:\n  - {{x_m: {OBSTACLE[0]}, y_m: {OBSTACLE[1]}, radius_m: {OBSTACLE[2]}}}\n"
)


# ---- the browser -----------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def browser(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    """Headless Chromium with its console log kept (fails, never skips, without Chromium)."""
    assert CHROMIUM.exists() and CHROMEDRIVER.exists(), (
        f"{CHROMIUM} / {CHROMEDRIVER} missing: the map's browser tests need Debian's chromium and "
        "chromium-driver (make venv installs them: apt-get install chromium chromium-driver)"
    )
    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for arg in (
        "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
        "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run",
        f"--user-data-dir={tmp_path_factory.mktemp('chromium')}", "--window-size=1200,800",
    ):  # fmt: skip
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(options=options, service=Service(str(CHROMEDRIVER)))
    try:
        # the page's viewport exactly 1200 x 800 (the window's size would include the browser's frame)
        driver.execute_cdp_cmd(
            "Emulation.setDeviceMetricsOverride",
            {"width": 1200, "height": 800, "deviceScaleFactor": 1, "mobile": False},
        )
        yield driver
    finally:
        driver.quit()


def open_map(driver: Any, url: str, timeout_s: float = 10.0) -> None:
    """Load the page and wait for its first update from the ground station."""
    driver.get_log("browser")  # drop what an earlier test left
    driver.get(url)
    wait_for(
        lambda: int(driver.find_element("tag name", "body").get_attribute("data-updates")) > 0, timeout_s
    )


def wait_for(cond: Callable[[], Any], timeout_s: float, what: str = "condition") -> Any:
    deadline = time.monotonic() + timeout_s
    while True:
        value = cond()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"{what}: not within {timeout_s:g} s")
        time.sleep(0.05)


def console_errors(driver: Any) -> list[dict[str, Any]]:
    return [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]


@dataclass(frozen=True)
class Marker:
    """The vehicle marker as drawn: its metres (data-*), the sample it shows, where it is on the screen."""

    x_m: float
    y_m: float
    time_boot_ms: int
    screen: tuple[float, float]
    expected_screen: tuple[float, float]  # where metres (x_m, y_m) are under the world transform


def marker(driver: Any) -> Marker | None:
    data = driver.execute_script(
        """const v = document.getElementById('vehicle');
        if (v.getAttribute('display') === 'none' || !v.dataset.xM) return null;
        const m = document.getElementById('world').transform.baseVal.consolidate().matrix;
        const t = v.transform.baseVal.getItem(0).matrix;  // translate(...) first, then rotate(yaw)
        return {x: +v.dataset.xM, y: +v.dataset.yM, boot: +v.dataset.timeBootMs, sx: t.e, sy: t.f,
                k: m.a, tx: m.e, ty: m.f};"""
    )
    if data is None:
        return None
    expected = (data["k"] * data["y"] + data["tx"], -data["k"] * data["x"] + data["ty"])
    return Marker(data["x"], data["y"], int(data["boot"]), (data["sx"], data["sy"]), expected)


def goals_drawn(driver: Any) -> list[dict[str, Any]]:
    return driver.execute_script(
        """return [...document.querySelectorAll('#goals .goal')].map(g => ({
            seq: +g.dataset.seq, index: +g.dataset.index, x: +g.dataset.xM, y: +g.dataset.yM,
            yaw: g.dataset.yawDeg, arrow: g.querySelector('.arrow') !== null,
            label: g.querySelector('text').textContent, current: g.classList.contains('current')}));"""
    )


def obstacles_drawn(driver: Any) -> list[dict[str, float]]:
    return driver.execute_script(
        """return [...document.querySelectorAll('#obstacles .obstacle')].map(c => ({
            x: +c.dataset.xM, y: +c.dataset.yM, r: +c.dataset.radiusM, cx: +c.getAttribute('cx'),
            cy: +c.getAttribute('cy'), world_r: +c.getAttribute('r')}));"""
    )


def drawn_points(driver: Any) -> list[list[float]]:
    """The planned path's polyline in world units: (east m, -north m) per point."""
    return driver.execute_script("return [...document.getElementById('path').points].map(p => [p.x, p.y]);")


def text_of(driver: Any, element_id: str) -> str:
    return str(driver.find_element("id", element_id).text)


# ---- the live flight -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Flight:
    url: str  # the vehicle's MAVLink
    tlogs: Path
    map_url: str


def start_map(procs: list[Any], *args: str, log: Any) -> str:
    """Start ``auv-gcs --json ... map ...``; its URL from its ready line (it prints it once it serves)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "groundstation", "--json", *args],
        stdout=subprocess.PIPE, stderr=log, text=True,
    )  # fmt: skip
    procs.append(proc)
    assert proc.stdout is not None
    line = proc.stdout.readline()
    data = json.loads(line) if line.startswith("{") else {}
    assert data.get("ok") and data.get("url"), f"auv-gcs map did not start: {line!r}"
    return str(data["url"])


@pytest.fixture(scope="module")
def flight(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Flight]:
    """The bench and the firmware in real time, the mission uploaded, armed and started by auv-gcs, and
    ``auv-gcs map`` serving; every process stopped at the end."""
    tmp = tmp_path_factory.mktemp("map_flight")
    channel = f"ws://127.0.0.1:{free_port()}/"
    mav_port = free_udp_port()
    url = f"udpout:127.0.0.1:{mav_port}"
    mission = tmp / "mission.yaml"
    mission.write_text(MISSION_YAML)
    tlogs = tmp / "tlogs"
    hil_cmd = bench_cmd(channel, ",".join(str(v) for v in START), 90)
    with processes() as procs, open(tmp / "procs.log", "w") as log:
        start_vehicle(procs, log, hil_cmd, onboard_cmd(channel, mav_port, tmp / "state"))
        upload_arm_start(url, tlogs, mission)
        map_url = start_map(
            procs, "--connect", url, "--tlog-dir", str(tlogs), "map", "--port", str(free_port()), log=log
        )
        yield Flight(url, tlogs, map_url)


def positions_in(tlogs: Path) -> dict[int, tuple[float, float, float]]:
    """The vehicle's LOCAL_POSITION_NED samples the ground stations recorded: time_boot_ms -> (unix s at
    arrival, x m, y m)."""
    out = {}
    for path in sorted(tlogs.glob("*.tlog")):
        for t_s, m in read_tlog(path):
            if m.get_type() == "LOCAL_POSITION_NED" and m.get_srcSystem() == 1:
                out[int(m.time_boot_ms)] = (t_s, float(m.x), float(m.y))
    return out


def _speed_mps(driver: Any) -> float:
    text = text_of(driver, "speed")
    return float(text.split()[0]) if text.endswith("m/s") else 0.0


def test_live_map_shows_the_flight(browser: Any, flight: Flight) -> None:
    # GIVEN the vehicle flying the mission and auv-gcs map serving
    # WHEN the page is opened
    open_map(browser, flight.map_url)
    # THEN it shows the vehicle running its first goal of two
    wait_for(lambda: text_of(browser, "state") == "RUNNING", 5.0, "state RUNNING")
    wait_for(lambda: text_of(browser, "goal") == "goal 1 of 2", 3.0, "goal 1 of 2")  # MISSION_CURRENT: 1 Hz
    assert re.fullmatch(r"-?\d+ m", text_of(browser, "dist")), text_of(browser, "dist")
    assert re.fullmatch(r"-?\d+\.\d\d m", text_of(browser, "xtrack")), text_of(browser, "xtrack")
    # AND the goals with their heading arrows and the obstacle at scale (its radius in metres)
    goals = wait_for(lambda: goals_drawn(browser), 5.0, "goals drawn")
    assert [(g["seq"], g["x"], g["y"], g["arrow"]) for g in goals] == [
        (i, x, y, True) for i, (x, y, _d, _yaw) in enumerate(GOALS)
    ]
    (obstacle,) = obstacles_drawn(browser)
    assert (obstacle["x"], obstacle["y"], obstacle["r"]) == OBSTACLE
    assert (obstacle["cx"], obstacle["cy"], obstacle["world_r"]) == (OBSTACLE[1], -OBSTACLE[0], OBSTACLE[2])
    # AND once the vehicle is under way (it starts from rest), over 3 s the marker moves with it: each
    # sample it shows is the vehicle's LOCAL_POSITION_NED of that time_boot_ms (as the map's link recorded
    # it), received within the last second, and the marker sits on the screen where those metres are
    wait_for(lambda: _speed_mps(browser) > 0.5, 15.0, "the vehicle under way (speed over 0.5 m/s)")
    samples: list[tuple[float, Marker]] = []
    t_end = time.monotonic() + 3.0
    while time.monotonic() < t_end:
        m = marker(browser)
        assert m is not None, "no vehicle marker"
        samples.append((time.time(), m))
        time.sleep(0.5)
    positions = positions_in(flight.tlogs)
    for t_read, m in samples:
        assert m.time_boot_ms in positions, f"the marker shows a sample never received: {m}"
        t_rx, x, y = positions[m.time_boot_ms]
        assert math.hypot(m.x_m - x, m.y_m - y) < 1.0, (m, x, y)
        assert -0.05 < t_read - t_rx < 1.0, f"the marker shows a sample {t_read - t_rx:.2f} s old"
        assert math.dist(m.screen, m.expected_screen) < 1.0, m
    first, last = samples[0][1], samples[-1][1]
    assert last.x_m - first.x_m > 1.0, "the marker did not move north with the vehicle"
    assert int(browser.find_element("id", "track").get_attribute("data-points")) > 5
    # AND the planned path the vehicle flies, once the ground station can read the vehicle's files
    path = browser.find_element("id", "path")
    if hasattr(MavClient, "read_file"):
        wait_for(lambda: int(path.get_attribute("data-points")) > 1, 5.0, "planned path drawn")
        assert path.get_attribute("data-kind") == "goal" and path.get_attribute("data-goal-index") == "0"
        east, minus_north = drawn_points(browser)[-1]  # the path ends at goal 1
        assert math.hypot(-minus_north - GOALS[0][0], east - GOALS[0][1]) < 0.5
    else:
        assert path.get_attribute("data-points") == "0"
        assert "cannot read the vehicle's files" in text_of(browser, "note")
    # AND the page logged no error
    assert console_errors(browser) == []
    if os.environ.get("AUV_MAP_SCREENSHOT") == "1":
        browser.save_screenshot(str(SCREENSHOT))


def test_replay_of_the_flight_s_tlog_follows_the_slider(browser: Any, flight: Flight, tmp_path: Path) -> None:
    # GIVEN the tlog the ground stations wrote during the flight (the upload, arm, start, the map's link)
    (tlog,) = sorted(flight.tlogs.glob("*.tlog"))[-1:]
    with processes() as procs, open(tmp_path / "map.log", "w") as log:
        url = start_map(
            procs,
            "--tlog-dir",
            str(tmp_path),
            "map",
            "--port",
            str(free_port()),
            "--tlog",
            str(tlog),
            log=log,
        )
        # WHEN the page is opened: the replay bar is there, over the recording's length
        open_map(browser, url)
        assert browser.find_element("tag name", "body").get_attribute("data-mode") == "replay"
        slider = browser.find_element("id", "slider")
        assert slider.is_displayed()
        length_s = float(slider.get_attribute("max"))
        assert length_s > 3.0

        def seek(fraction: float) -> Marker:
            before = browser.find_element("tag name", "body").get_attribute("data-t-s")
            browser.execute_script(
                "const s = arguments[0]; s.value = arguments[1]; s.dispatchEvent(new Event('input'));",
                slider,
                f"{fraction * length_s:.1f}",
            )
            wait_for(
                lambda: browser.find_element("tag name", "body").get_attribute("data-t-s") != before,
                3.0,
                "the picture of the new time",
            )
            return wait_for(lambda: marker(browser), 3.0, "the vehicle marker")

        # THEN moving the slider moves the marker (north: the vehicle flew north to goal 1)
        early, late = seek(0.5), seek(0.98)
        assert late.x_m - early.x_m > 0.2, (early, late)
        assert math.dist(late.screen, late.expected_screen) < 1.0
        # AND the path the map's link read during the flight (the recorded FTP reads)
        assert len(drawn_points(browser)) > 1
        # AND the plans are the ones the recording uploaded
        assert [(g["x"], g["y"]) for g in goals_drawn(browser)] == [(x, y) for x, y, _d, _yaw in GOALS]
        assert [(o["x"], o["y"], o["r"]) for o in obstacles_drawn(browser)] == [OBSTACLE]
        # AND play moves the replay's time on from where the slider was
        seek(0.5)
        t_before = float(browser.find_element("tag name", "body").get_attribute("data-t-s"))
        browser.find_element("id", "play").click()
        wait_for(
            lambda: (
                float(browser.find_element("tag name", "body").get_attribute("data-t-s")) > t_before + 1.0
            ),
            3.0,
            "replay playing",
        )
        browser.find_element("id", "play").click()
        assert browser.find_element("id", "play").get_attribute("data-playing") == "false"
        assert console_errors(browser) == []


# ---- the planned path, from a scripted client --------------------------------------------------------------
def _wire(msg: Any, src: tuple[int, int] = (1, 1)) -> Any:
    buf = msg.pack(mavlink.MAVLink(None, srcSystem=src[0], srcComponent=src[1]))
    return mavlink.MAVLink(None).decode(bytearray(buf))


class ScriptedClient:
    """The part of :class:`MavClient` the map uses, scripted: a vehicle flying north at 1 m/s from the
    origin, a goal and an obstacle (or ``mission``, MISSION_CURRENT ``current`` (seq, total)), a path file
    that answers until ``path_gone`` is set, and GPS_GLOBAL_ORIGIN ``origin`` (lat degE7, lon degE7, alt mm)
    sent when asked for (MAV_CMD_REQUEST_MESSAGE)."""

    PATH: ClassVar[dict[str, Any]] = {"version": 1, "kind": "goal", "goal_index": 0, "frame": "local_ned",
            "points_m": [[0.0, 0.0, 1.0], [5.0, 1.0, 1.0], [10.0, 0.0, 1.0], [20.0, 0.0, 1.0]]}  # fmt: skip

    def __init__(
        self,
        mission: list[Item] | None = None,
        current: tuple[int, int] = (0, 1),
        origin: tuple[int, int, int] = (351_000_000, 1_290_400_000, 0),
    ) -> None:
        self.target = (1, 1)
        self.on_message: Callable[[Any], None] | None = None
        self.t0 = time.monotonic()
        self.path_gone = threading.Event()
        self.reads = 0
        self.mission = mission if mission is not None else [goal_item(20.0, 0.0, 1.0, None)]
        self.current, self.origin = current, origin
        self._answers: list[Any] = []
        self.reported = threading.Event()  # its first messages went to the map

    def send(self, msg: Any) -> None:
        if msg.get_type() == "COMMAND_LONG" and msg.command == mavlink.MAV_CMD_REQUEST_MESSAGE:
            if int(msg.param1) == mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN:
                self._answers.append(_wire(mavlink.MAVLink_gps_global_origin_message(*self.origin, 0)))

    def _heartbeat(self) -> Any:
        return _wire(
            mavlink.MAVLink_heartbeat_message(
                mavlink.MAV_TYPE_SUBMARINE, mavlink.MAV_AUTOPILOT_GENERIC, 129, 3, mavlink.MAV_STATE_ACTIVE, 3
            )
        )

    def wait_heartbeat(self, timeout_s: float) -> Any:
        return self._heartbeat()

    def recv(self, timeout_s: float) -> Any:
        time.sleep(min(timeout_s, 0.05))
        t = time.monotonic() - self.t0
        msgs = [
            self._heartbeat(),
            _wire(mavlink.MAVLink_local_position_ned_message(int(t * 1000), t, 0.0, 1.0, 1.0, 0.0, 0.0)),
            _wire(mavlink.MAVLink_attitude_message(int(t * 1000), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
            _wire(mavlink.MAVLink_mission_current_message(*self.current, mavlink.MISSION_STATE_ACTIVE, 1)),
            *self._answers,
        ]
        self._answers = []
        for m in msgs:
            if self.on_message is not None:
                self.on_message(m)
        if self.on_message is not None:
            self.reported.set()
        return msgs[-1]

    def download(self, mission_type: int) -> list[Any]:
        if mission_type == mavlink.MAV_MISSION_TYPE_MISSION:
            return list(self.mission)
        return [obstacle_item(8.0, 6.0, 2.5)]

    def read_file(self, path: str, on_other: Callable[[Any], None] | None = None) -> bytes:
        assert path == PLANNED_PATH_FILE
        self.reads += 1
        if self.path_gone.is_set():
            raise LinkError(f"{path}: no such file")
        return json.dumps(self.PATH).encode()


@contextlib.contextmanager
def serving(client: ScriptedClient, *, push: bool = True) -> Iterator[str]:
    """The real link thread, model, server and page in this process, on a free port; its URL. ``push``
    False: the server sends a page its first picture only (as if its pusher had stopped)."""
    model, lock, stop = MapModel(), threading.Lock(), threading.Event()
    link = LiveLink(client, model, lock, path_period_s=0.2)  # type: ignore[arg-type]
    app = make_app(LiveSource(model, lock, "scripted"), live=push)
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen()
    loop = asyncio.new_event_loop()
    runner = web.AppRunner(app, access_log=None, handle_signals=False, shutdown_timeout=1.0)
    ready = threading.Event()

    def serve() -> None:
        asyncio.set_event_loop(loop)
        loop.run_until_complete(runner.setup())
        loop.run_until_complete(web.SockSite(runner, sock).start())
        ready.set()
        loop.run_forever()
        loop.run_until_complete(runner.cleanup())

    threads = [threading.Thread(target=serve), threading.Thread(target=link.run, args=(stop,))]
    for t in threads:
        t.start()
    try:
        assert ready.wait(5.0)
        yield f"http://127.0.0.1:{sock.getsockname()[1]}/"
    finally:
        stop.set()
        loop.call_soon_threadsafe(loop.stop)
        for t in threads:
            t.join(5.0)
        loop.close()


def test_the_planned_path_is_drawn_and_removed(browser: Any) -> None:
    # GIVEN the map's link thread reading a scripted vehicle's path file
    client = ScriptedClient()
    with serving(client) as url:
        # WHEN the page is opened
        open_map(browser, url)
        path = browser.find_element("id", "path")
        # THEN it draws the file's points in metres (east, -north) as the vehicle's path to goal 0
        wait_for(lambda: path.get_attribute("data-points") == "4", 5.0, "the planned path drawn")
        assert path.get_attribute("data-kind") == "goal" and path.get_attribute("data-goal-index") == "0"
        assert drawn_points(browser) == [[p[1], -p[0]] for p in ScriptedClient.PATH["points_m"]]
        assert wait_for(lambda: marker(browser), 3.0, "the vehicle marker").x_m > 0.0
        # AND the wheel zooms, a drag pans (both stop the auto-fit), "fit" fits again; markers stay put
        svg, fit = browser.find_element("id", "map"), browser.find_element("id", "fit")
        k0 = float(svg.get_attribute("data-px-per-m"))
        ActionChains(browser).scroll_from_origin(ScrollOrigin.from_element(svg), 0, -400).perform()
        wait_for(lambda: float(svg.get_attribute("data-px-per-m")) > 1.2 * k0, 2.0, "zoomed in")
        ActionChains(browser).move_to_element(svg).click_and_hold().move_by_offset(80, 40).release().perform()
        assert "on" not in (fit.get_attribute("class") or "")
        m = marker(browser)
        assert m is not None and math.dist(m.screen, m.expected_screen) < 1.0
        fit.click()
        wait_for(lambda: "on" in (fit.get_attribute("class") or ""), 2.0, "auto-fit back on")
        # WHEN the vehicle's file goes away (it flies no path)
        client.path_gone.set()
        # THEN the path is gone and the page says why
        wait_for(lambda: path.get_attribute("data-points") == "0", 5.0, "the planned path removed")
        assert "no such file" in text_of(browser, "note")
        assert console_errors(browser) == []


def test_a_qgc_plan_is_drawn_about_the_origin_and_numbered_from_its_first_goal(browser: Any) -> None:
    # GIVEN the vehicle's plan as QGC uploads it: the home placeholder, then a waypoint 0.0001 deg (11.13 m)
    # north of the origin 2 m down (relative altitude -2), then a local goal; the vehicle flies the first
    # goal: MISSION_CURRENT seq 1 (the home is seq 0), total 2
    waypoint = Item(mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_CMD_NAV_WAYPOINT, 0.0, 0.0, 0.0,
                    math.nan, 351_001_000, 1_290_400_000, -2.0)  # fmt: skip
    mission = [home_item(35.1, 129.04, 0.0), waypoint, goal_item(20.0, 5.0, 1.0, None)]
    client = ScriptedClient(mission=mission, current=(1, 2))
    with serving(client) as url:
        # WHEN the page is opened
        open_map(browser, url)
        # THEN it says the vehicle flies goal 1 of 2 (not 2 of 2: the home is no goal)
        wait_for(lambda: text_of(browser, "goal") == "goal 1 of 2", 5.0, "goal 1 of 2")
        # AND both goals are drawn, the global one in metres about the origin the link asked for, the
        # first one current and labelled 1
        goals = wait_for(lambda: len(goals_drawn(browser)) == 2 and goals_drawn(browser), 5.0, "2 goals")
        assert [(g["seq"], g["index"], g["label"], g["current"]) for g in goals] == [
            (1, 0, "1", True),
            (2, 1, "2", False),
        ]
        assert (goals[0]["x"], goals[0]["y"]) == (11.1319, 0.0) and (goals[1]["x"], goals[1]["y"]) == (20, 5)
        assert "not drawn" not in text_of(browser, "note")
        assert console_errors(browser) == []


def test_a_goals_acceptance_radius_is_drawn_as_a_circle_of_that_radius(browser: Any) -> None:
    # GIVEN the vehicle's plan: a goal with its own 3.5 m acceptance radius (param2), one with the default
    mission = [goal_item(20.0, 5.0, 1.0, 90.0, radius_m=3.5), goal_item(40.0, 5.0, 1.0, None)]
    with serving(ScriptedClient(mission=mission, current=(0, 2))) as url:
        # WHEN the page is opened
        open_map(browser, url)
        # THEN the first goal has a circle of 3.5 m round it, in metres (east, -north) like the obstacles
        circles = wait_for(
            lambda: browser.execute_script(
                """return [...document.querySelectorAll('#goal-radii circle.goal-radius')].map(c =>
                    ['cx', 'cy', 'r', 'data-radius-m', 'data-index'].map(k => Number(c.getAttribute(k))));"""
            ),
            5.0,
            "a radius drawn",
        )
        assert circles == [[5.0, -20.0, 3.5, 3.5, 0.0]]
        # AND the goal's title says it; the other goal arrives within the vehicle's default
        titles = browser.execute_script(
            "return [...document.querySelectorAll('#goals title')].map(t => t.textContent);"
        )
        assert "radius 3.5 m" in titles[0] and "radius: the vehicle's" in titles[1], titles
        assert console_errors(browser) == []


def test_the_link_badge_says_when_no_update_came_for_3_s(browser: Any) -> None:
    # GIVEN a page that got its first picture (the vehicle in it), and then no update (the server pushes none)
    client = ScriptedClient()
    with serving(client, push=False) as url:
        assert client.reported.wait(5.0)
        open_map(browser, url)
        link = browser.find_element("id", "link")
        assert "stale" not in (link.get_attribute("class") or "")
        # THEN after 3 s the badge says the view is old
        wait_for(lambda: "stale" in (link.get_attribute("class") or ""), 5.0, "the link badge stale")
        assert re.fullmatch(r"no update for [3-9] s", link.text), link.text
        assert "stale" in (browser.find_element("id", "vehicle").get_attribute("class") or "")
        assert console_errors(browser) == []


# ---- the command line ------------------------------------------------------------------------------------
def test_a_port_in_use_is_one_line_and_exit_2(tmp_path: Path) -> None:
    # GIVEN a port another program listens on
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        # WHEN auv-gcs map is asked to serve there
        out = subprocess.run(
            [sys.executable, "-m", "groundstation", "--tlog-dir", str(tmp_path), "map", "--port", str(port)],
            capture_output=True, text=True, timeout=30, check=False,
        )  # fmt: skip
    # THEN one line says so, exit 2
    assert out.returncode == 2, out
    lines = (out.stdout + out.stderr).strip().splitlines()
    assert lines == [f"error: cannot serve on 127.0.0.1:{port}: Address already in use"], lines
