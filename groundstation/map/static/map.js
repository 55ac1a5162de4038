/* ISiMI100 map: draws the pictures the ground station pushes over /ws (groundstation/map/state.py).
 *
 * Frame: local NED metres, north up, east right. The world group (obstacles, planned path, track) is drawn in
 * metres at (east, -north) under one transform, screen = (k * east + tx, -k * north + ty); goals, the vehicle,
 * the grid and the scale bar are placed in screen pixels with the same numbers (their size does not change
 * with the zoom). Every drawn thing carries its metres in data-* attributes (the browser test reads them).
 * A number the ground station could not give is null: a goal without its position or depth, an obstacle
 * without its position or radius, is not drawn (the note says how many). Live, an update comes at least
 * once a second: none for STALE_S and the link badge says so (class "stale") and the vehicle turns grey.
 */
"use strict";
(function () {
  const SVG_NS = "http://www.w3.org/2000/svg";
  const STALE_S = 3;
  const $ = (id) => document.getElementById(id);
  const svg = $("map");
  const world = $("world");
  const S = {
    mode: "", t0: 0, t1: 0, ws: null, updates: 0, lastUpdateMs: 0, stale: false,
    telemetry: null, plan: { goals: [], obstacles: [] }, path: null, track: [], trackText: "",
  };
  const view = { k: 8, tx: 0, ty: 0, auto: true };
  const replay = { t: 0, playing: false, timer: null };

  // ---- geometry ------------------------------------------------------------------------------------------
  function size() {
    const r = svg.getBoundingClientRect();
    return [r.width || 800, r.height || 600];
  }
  function toScreen(n, e) { return [view.k * e + view.tx, -view.k * n + view.ty]; }
  function toWorld(sx, sy) { return [(view.ty - sy) / view.k, (sx - view.tx) / view.k]; }
  function el(tag, attrs, parent) {
    const e = document.createElementNS(SVG_NS, tag);
    for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, String(v));
    if (parent) parent.appendChild(e);
    return e;
  }
  const finite = (v) => typeof v === "number" && Number.isFinite(v);
  const fmt = (v, unit, digits) => (finite(v) ? `${v.toFixed(digits)} ${unit}` : "-");
  const r2 = (v) => Math.round(v * 100) / 100;
  const drawable = {
    goal: (g) => finite(g.x_m) && finite(g.y_m) && finite(g.depth_m),
    obstacle: (o) => finite(o.x_m) && finite(o.y_m) && finite(o.radius_m) && o.radius_m >= 0,
  };

  function bounds() {
    let nMin = Infinity, nMax = -Infinity, eMin = Infinity, eMax = -Infinity;
    const add = (n, e, r) => {
      if (!finite(n) || !finite(e)) return;
      nMin = Math.min(nMin, n - r); nMax = Math.max(nMax, n + r);
      eMin = Math.min(eMin, e - r); eMax = Math.max(eMax, e + r);
    };
    for (const g of S.plan.goals) if (drawable.goal(g)) add(g.x_m, g.y_m, 1);
    for (const o of S.plan.obstacles) if (drawable.obstacle(o)) add(o.x_m, o.y_m, o.radius_m);
    if (S.path) for (const p of S.path.points_m) add(p[0], p[1], 0);
    for (const p of S.track) add(p[0], p[1], 0);
    const v = S.telemetry && S.telemetry.vehicle;
    if (v) add(v.x_m, v.y_m, 1);
    return finite(nMin) ? [nMin, nMax, eMin, eMax] : [-10, 10, -10, 10];
  }

  function fit() {
    const [w, h] = size();
    const [nMin, nMax, eMin, eMax] = bounds();
    const pad = 60;
    const spanN = Math.max(nMax - nMin, 10), spanE = Math.max(eMax - eMin, 10);
    view.k = Math.max(1e-3, Math.min((w - 2 * pad) / spanE, (h - 2 * pad) / spanN));
    view.tx = w / 2 - view.k * (eMin + eMax) / 2;
    view.ty = h / 2 + view.k * (nMin + nMax) / 2;
  }

  /** The grid step (metres): 1, 2 or 5 times a power of ten, at least ``px`` pixels apart. */
  function gridStep(px) {
    const raw = px / view.k;
    const p = Math.pow(10, Math.floor(Math.log10(raw)));
    for (const m of [1, 2, 5, 10]) if (m * p >= raw) return m * p;
    return 10 * p;
  }

  // ---- drawing -------------------------------------------------------------------------------------------
  function drawGrid() {
    const g = $("grid");
    g.replaceChildren();
    const [w, h] = size();
    const step = gridStep(70);
    const [nTop, eLeft] = toWorld(0, 0);
    const [nBottom, eRight] = toWorld(w, h);
    const label = (v) => `${r2(v)}`;
    for (let e = Math.ceil(eLeft / step) * step, i = 0; e <= eRight && i < 200; e += step, i++) {
      const [x] = toScreen(0, e);
      el("line", { x1: x, y1: 0, x2: x, y2: h, class: Math.abs(e) < step / 2 ? "axis" : "" }, g);
      el("text", { x: x + 3, y: 14 }, g).textContent = `E ${label(e)}`;
    }
    for (let n = Math.ceil(nBottom / step) * step, i = 0; n <= nTop && i < 200; n += step, i++) {
      const [, y] = toScreen(n, 0);
      el("line", { x1: 0, y1: y, x2: w, y2: y, class: Math.abs(n) < step / 2 ? "axis" : "" }, g);
      if (y > 24) el("text", { x: 4, y: y - 3 }, g).textContent = `N ${label(n)}`;
    }
  }

  function drawScale() {
    const [w, h] = size();
    const step = gridStep(80);
    const bar = $("scalebar");
    bar.setAttribute("transform", `translate(20,${h - 20})`);
    bar.querySelector("line").setAttribute("x2", String(step * view.k));
    bar.querySelector("rect").setAttribute("width", String(step * view.k + 20));
    $("scaletext").textContent = `${r2(step)} m`;
    $("north").setAttribute("transform", `translate(${w - 30},${70})`);
    svg.dataset.pxPerM = String(view.k);
  }

  function drawObstacles() {
    const g = $("obstacles");
    g.replaceChildren();
    for (const o of S.plan.obstacles.filter(drawable.obstacle)) {
      el("circle", {
        class: "obstacle", cx: o.y_m, cy: -o.x_m, r: o.radius_m, "vector-effect": "non-scaling-stroke",
        "data-x-m": o.x_m, "data-y-m": o.y_m, "data-radius-m": o.radius_m,
      }, g);
    }
  }

  /* Each goal's own acceptance radius (MAVLink param2) as a circle in metres; a goal without one arrives
   * within the vehicle's default (MIS_ARRIVE_R_M), not drawn. */
  function drawGoalRadii() {
    const g = $("goal-radii");
    g.replaceChildren();
    for (const goal of S.plan.goals.filter(drawable.goal)) {
      if (!(finite(goal.radius_m) && goal.radius_m > 0)) continue;
      el("circle", {
        class: "goal-radius", cx: goal.y_m, cy: -goal.x_m, r: goal.radius_m, "vector-effect": "non-scaling-stroke",
        "data-index": goal.index, "data-x-m": goal.x_m, "data-y-m": goal.y_m, "data-radius-m": goal.radius_m,
      }, g);
    }
  }

  function drawPath() {
    const p = $("path");
    const pts = S.path ? S.path.points_m : [];
    p.setAttribute("points", pts.map((q) => `${q[1]},${-q[0]}`).join(" "));
    p.dataset.points = String(pts.length);
    p.dataset.kind = S.path ? S.path.kind : "";
    p.dataset.goalIndex = S.path ? String(S.path.goal_index) : "";
  }

  function drawTrack(from, points) {
    if (from < S.track.length) {
      S.track.length = from;
      S.trackText = S.track.map((q) => `${q[1]},${-q[0]}`).join(" ");
    }
    if (points.length) {
      const more = points.map((q) => `${q[1]},${-q[0]}`).join(" ");
      S.trackText = S.trackText ? `${S.trackText} ${more}` : more;
      for (const q of points) S.track.push(q);
    }
    const t = $("track");
    t.setAttribute("points", S.trackText);
    t.dataset.points = String(S.track.length);
  }

  function drawGoals() {
    const g = $("goals");
    g.replaceChildren();
    const t = S.telemetry || {};
    const cur = t.goal ? t.goal.index : -1;  // the goal index (0-based), as the goals carry theirs
    const flying = ["ARMED", "RUNNING", "HOLD"].includes(t.state);
    for (const goal of S.plan.goals.filter(drawable.goal)) {
      const [x, y] = toScreen(goal.x_m, goal.y_m);
      let cls = "goal";
      if (goal.index === cur && flying) cls += " current";
      else if (goal.index < cur || t.state === "COMPLETE") cls += " reached";
      const m = el("g", {
        class: cls, transform: `translate(${x},${y})`, "data-seq": goal.seq, "data-index": goal.index,
        "data-x-m": goal.x_m, "data-y-m": goal.y_m, "data-depth-m": goal.depth_m,
        "data-yaw-deg": goal.yaw_deg ?? "", "data-radius-m": goal.radius_m ?? "",
      }, g);
      if (finite(goal.yaw_deg)) {
        const a = el("g", { class: "arrow", transform: `rotate(${goal.yaw_deg})` }, m);
        el("line", { x1: 0, y1: -8, x2: 0, y2: -30 }, a);
        el("polygon", { points: "0,-38 6,-28 -6,-28" }, a);
      }
      el("circle", { r: 9 }, m);
      el("text", { "text-anchor": "middle", dy: "0.35em" }, m).textContent = String(goal.index + 1);
      el("title", {}, m).textContent =
        `goal ${goal.index + 1}: N ${goal.x_m} m, E ${goal.y_m} m, depth ${goal.depth_m} m` +
        (finite(goal.yaw_deg) ? `, yaw ${goal.yaw_deg} deg` : ", yaw: the planner's") +
        (finite(goal.radius_m) && goal.radius_m > 0 ? `, radius ${goal.radius_m} m` : ", radius: the vehicle's");
    }
  }

  function drawVehicle() {
    const m = $("vehicle");
    const t = S.telemetry || {};
    const v = t.vehicle;
    if (!v) {
      m.setAttribute("display", "none");
      for (const k of ["xM", "yM", "depthM", "yawDeg", "timeBootMs"]) m.dataset[k] = "";
      return;
    }
    const [x, y] = toScreen(v.x_m, v.y_m);
    m.removeAttribute("display");
    m.setAttribute("transform", `translate(${x},${y}) rotate(${finite(v.yaw_deg) ? v.yaw_deg : 0})`);
    m.dataset.xM = String(v.x_m);
    m.dataset.yM = String(v.y_m);
    m.dataset.depthM = String(v.depth_m ?? "");
    m.dataset.yawDeg = String(v.yaw_deg ?? "");
    m.dataset.timeBootMs = String(v.time_boot_ms);
    m.classList.toggle("stale", S.stale || t.link !== "ok" || v.age_s > STALE_S);
  }

  function render() {
    if (view.auto) fit();
    world.setAttribute("transform", `matrix(${view.k} 0 0 ${view.k} ${view.tx} ${view.ty})`);
    drawGrid();
    drawScale();
    drawGoals();
    drawVehicle();
  }

  // ---- the numbers ---------------------------------------------------------------------------------------
  function setLink(text, bad) {
    const l = $("link");
    l.textContent = text;
    l.classList.toggle("bad", Boolean(bad));
    l.classList.toggle("stale", S.stale);
  }

  /** Live, connected and no update for STALE_S: what the page shows is old; say so (checked twice a second). */
  function checkStale() {
    const age = (performance.now() - S.lastUpdateMs) / 1000;
    const stale = S.mode === "live" && S.ws !== null && S.ws.readyState === WebSocket.OPEN &&
      S.updates > 0 && age >= STALE_S;
    if (stale) {
      S.stale = true;
      setLink(`no update for ${Math.floor(age)} s`, true);
      drawVehicle();
    } else if (S.stale) {  // (an update resets it itself; here the websocket closed: its text stays)
      S.stale = false;
      $("link").classList.remove("stale");
      drawVehicle();
    }
  }

  function showNumbers() {
    const t = S.telemetry;
    const st = $("state");
    st.textContent = t.state || "-";
    st.dataset.state = t.state || "";
    const goal = $("goal");
    if (!t.goal) goal.textContent = "goal - of -";
    else if (t.goal.total === 0) goal.textContent = "no mission";
    else goal.textContent = `goal ${Math.min(t.goal.index + 1, t.goal.total)} of ${t.goal.total}`;
    goal.dataset.seq = t.goal ? String(t.goal.seq) : "";
    goal.dataset.index = t.goal ? String(t.goal.index) : "";
    goal.dataset.total = t.goal ? String(t.goal.total) : "";
    const e = t.errors || {};
    const v = t.vehicle || {};
    $("dist").textContent = fmt(e.goal_distance_m, "m", 0);
    $("xtrack").textContent = fmt(e.cross_track_m, "m", 2);
    $("deptherr").textContent = fmt(e.depth_error_m, "m", 2);
    $("yawerr").textContent = fmt(e.yaw_error_deg, "°", 0);
    $("depth").textContent = fmt(v.depth_m, "m", 2);
    $("heading").textContent = finite(v.yaw_deg) ? `${Math.round(v.yaw_deg) % 360} °` : "-";
    $("speed").textContent = fmt(v.speed_mps, "m/s", 2);
    const where = S.mode === "replay" ? "replay: " : "";
    setLink(where + (t.link === "ok" ? `link ok${t.armed ? ", armed" : ""}` : t.link), t.link !== "ok");
    const list = $("texts");
    list.replaceChildren();
    for (const x of t.texts || []) {
      const li = document.createElement("li");
      li.textContent = x.text;
      if (x.severity <= 3) li.className = "error";
      else if (x.severity === 4) li.className = "warn";
      list.appendChild(li);
    }
    const notes = [];
    const waiting = S.plan.origin ? "" : "; global ones wait for the vehicle's origin";
    if (S.plan.goals_not_drawn) notes.push(`${S.plan.goals_not_drawn} mission items not drawn (no waypoint with a place${waiting})`);
    if (S.plan.fence_not_drawn) notes.push(`${S.plan.fence_not_drawn} fence items not drawn (no exclusion circle with a place${waiting})`);
    const badGoals = S.plan.goals.filter((g) => !drawable.goal(g)).length;
    const badObstacles = S.plan.obstacles.filter((o) => !drawable.obstacle(o)).length;
    if (badGoals) notes.push(`${badGoals} goals not drawn (a position or depth that is no number)`);
    if (badObstacles) notes.push(`${badObstacles} obstacles not drawn (a position or radius that is no number)`);
    if (t.note) notes.push(t.note);
    $("note").textContent = notes.join("; ");
  }

  // ---- messages from the ground station ------------------------------------------------------------------
  function onHello(m) {
    S.mode = m.mode;
    document.body.dataset.mode = m.mode;
    document.title = `ISiMI100 map: ${m.source}`;
    if (m.mode === "replay") {
      S.t0 = m.t0_s;
      S.t1 = m.t1_s;
      replay.t = S.t0;
      const slider = $("slider");
      slider.min = "0";
      slider.max = (S.t1 - S.t0).toFixed(1);
      slider.value = "0";
      $("replay").hidden = false;
      showClock();
    }
  }

  function onUpdate(m) {
    S.lastUpdateMs = performance.now();
    S.stale = false;
    S.telemetry = m.telemetry;
    if ("plan" in m) {
      S.plan = m.plan;
      drawObstacles();
      drawGoalRadii();
    }
    if ("path" in m) {
      S.path = m.path;
      drawPath();
    }
    drawTrack(m.track_from, m.track);
    showNumbers();
    render();
    S.updates += 1;
    document.body.dataset.updates = String(S.updates);
    document.body.dataset.tS = String(m.t_s);
  }

  function connect() {
    const ws = new WebSocket(`${location.protocol === "https:" ? "wss:" : "ws:"}//${location.host}/ws`);
    S.ws = ws;
    ws.onmessage = (ev) => {
      const m = JSON.parse(ev.data);
      if (m.type === "hello") onHello(m);
      else if (m.type === "update") onUpdate(m);
    };
    ws.onclose = () => {
      S.ws = null;
      setLink("no connection to the ground station: retrying", true);
      setTimeout(connect, 1000);
    };
  }

  // ---- replay --------------------------------------------------------------------------------------------
  function showClock() {
    $("clock").textContent = `${(replay.t - S.t0).toFixed(1)} / ${(S.t1 - S.t0).toFixed(1)} s`;
  }
  function seek() {
    showClock();
    if (S.ws && S.ws.readyState === WebSocket.OPEN) S.ws.send(JSON.stringify({ type: "seek", t_s: replay.t }));
  }
  function setPlaying(on) {
    replay.playing = on;
    const b = $("play");
    b.dataset.playing = String(on);
    b.textContent = on ? "\u275a\u275a pause" : "\u25b6 play";
    clearInterval(replay.timer);
    replay.timer = null;
    if (on) {
      if (replay.t >= S.t1) replay.t = S.t0;
      replay.timer = setInterval(() => {
        replay.t = Math.min(S.t1, replay.t + 0.1 * Number($("playspeed").value));
        $("slider").value = (replay.t - S.t0).toFixed(1);
        seek();
        if (replay.t >= S.t1) setPlaying(false);
      }, 100);
    }
  }
  $("slider").addEventListener("input", () => {
    replay.t = S.t0 + Number($("slider").value);
    seek();
  });
  $("play").addEventListener("click", () => setPlaying(!replay.playing));

  // ---- zoom and pan --------------------------------------------------------------------------------------
  function setAuto(on) {
    view.auto = on;
    $("fit").classList.toggle("on", on);
  }
  function zoomAt(sx, sy, factor) {
    const [n, e] = toWorld(sx, sy);
    view.k = Math.min(5000, Math.max(0.01, view.k * factor));
    view.tx = sx - view.k * e;
    view.ty = sy + view.k * n;
    setAuto(false);
    render();
  }
  svg.addEventListener("wheel", (ev) => {
    ev.preventDefault();
    zoomAt(ev.offsetX, ev.offsetY, Math.exp(-ev.deltaY * 0.0015));
  }, { passive: false });
  let drag = null;
  svg.addEventListener("pointerdown", (ev) => {
    drag = { x: ev.clientX, y: ev.clientY, tx: view.tx, ty: view.ty };
    svg.setPointerCapture(ev.pointerId);
    svg.classList.add("dragging");
  });
  svg.addEventListener("pointermove", (ev) => {
    if (!drag) return;
    const dx = ev.clientX - drag.x, dy = ev.clientY - drag.y;
    if (view.auto && Math.hypot(dx, dy) < 3) return;
    setAuto(false);
    view.tx = drag.tx + dx;
    view.ty = drag.ty + dy;
    render();
  });
  const endDrag = () => { drag = null; svg.classList.remove("dragging"); };
  svg.addEventListener("pointerup", endDrag);
  svg.addEventListener("pointercancel", endDrag);
  $("fit").addEventListener("click", () => { setAuto(true); render(); });
  $("zoomin").addEventListener("click", () => { const [w, h] = size(); zoomAt(w / 2, h / 2, 1.5); });
  $("zoomout").addEventListener("click", () => { const [w, h] = size(); zoomAt(w / 2, h / 2, 1 / 1.5); });
  window.addEventListener("resize", render);

  setAuto(true);
  render();
  connect();
  setInterval(checkStale, 500);
})();
