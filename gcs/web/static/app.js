// The station's map page: the mission log's records (gcs/web/feed.py) drawn on a
// Leaflet map, live over a WebSocket or replayed with a time slider.
//
// One model for both: records are applied in order to `state` (apply); live, as
// they come; in a replay, those up to the slider's time. The page keeps no model of
// its own beyond what the records say, but for what it draws from them (the frontier
// from the map, the tracks from the poses).
"use strict";

const GRID_UNKNOWN = 0, GRID_FREE = 1, GRID_OBSTACLE = 2, GRID_COVERED = 3;
const EARTH_RADIUS_M = 6378137.0;  // core/geo.py
const COLOURS = ["#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#7f7f7f", "#1f77b4", "#d62728"];
const LEVELS = {1: "debug", 2: "info", 3: "warning", 4: "error", 5: "fatal"};
const TASKS = {exploring: "exploring", transit: "to a new area", returning: "to charge", charging: "charging",
  idle: "idle", homing: "going home", done: "done", lost: "lost"};
const MAX_EVENTS_SHOWN = 300;

let config = {mode: "live", title: "", tiles: null};
let state = emptyState();
let view = null;  // the map and its layers, made when the mission's meta arrives
let drawPending = false;

function emptyState() {
  return {meta: null, map: null, mapVersion: 0, btps: [], progress: null,
          vehicles: new Map(), events: [], t: 0};
}

function vehicle(sysid) {
  let v = state.vehicles.get(sysid);
  if (!v) {
    // Coloured by system id, so that a vehicle keeps its colour live, in a replay and on a seek.
    v = {sysid, status: null, battery: null, pose: null, track: [], colour: COLOURS[(sysid - 1) % COLOURS.length]};
    state.vehicles.set(sysid, v);
  }
  return v;
}

// -- the records ---------------------------------------------------------------------

function apply(record) {
  const {topic, t, data} = record;
  state.t = Math.max(state.t, t);
  if (topic === "/run/meta") { state.meta = data; return; }
  if (topic === "/map") { state.map = data; state.mapVersion++; return; }
  if (topic === "/run/progress") { state.progress = data; return; }
  if (topic === "/events") { state.events.push(data); return; }
  if (topic === "/scene/btps") {
    const entity = (data.entities || [])[0];
    const cells = entity && (entity.metadata || []).find(m => m.key === "cells");
    state.btps = cells ? JSON.parse(cells.value) : [];
    return;
  }
  const m = /^\/vehicle\/(\d+)\/(pose|status|battery)$/.exec(topic);
  if (!m) return;
  const v = vehicle(Number(m[1]));
  if (m[2] === "status") v.status = data;
  else if (m[2] === "battery") v.battery = data;
  else {
    v.pose = data.pose;
    const p = data.pose.position, last = v.track[v.track.length - 1];
    if (!last || last[0] !== p.x || last[1] !== p.y) v.track.push([p.x, p.y]);
  }
}

// -- geometry: x east, y north, metres from the map's north-west corner ---------------

function latLng(x, y) {
  if (!config.tiles) return L.latLng(y, x);  // a plain plane (CRS.Simple)
  const o = state.meta.origin, perDegLat = Math.PI * EARTH_RADIUS_M / 180;
  const perDegLon = perDegLat * Math.cos(o.lat_deg * Math.PI / 180);
  return L.latLng(o.lat_deg + y / perDegLat, o.lon_deg + x / perDegLon);
}

function cellCentre(cell) {
  const s = state.meta.cell_size_m;
  return latLng((cell[1] + 0.5) * s, -(cell[0] + 0.5) * s);
}

function headingDeg(pose) {
  const q = pose.orientation, yaw = 2 * Math.atan2(q.z, q.w);  // from east, anticlockwise
  return 90 - yaw * 180 / Math.PI;
}

// -- drawing -------------------------------------------------------------------------

function makeView() {
  const meta = state.meta, s = meta.cell_size_m, [rows, cols] = meta.shape;
  const options = config.tiles ? {} : {crs: L.CRS.Simple, minZoom: -5};
  const map = L.map("map", {...options, zoomSnap: 0.25, attributionControl: !!config.tiles});
  if (config.tiles) L.tileLayer(config.tiles, {maxZoom: 22, maxNativeZoom: 19}).addTo(map);
  const bounds = L.latLngBounds(latLng(0, -rows * s), latLng(cols * s, 0));
  const canvas = document.createElement("canvas");
  canvas.width = cols; canvas.height = rows;
  const grid = L.imageOverlay(canvas.toDataURL(), bounds, {className: "grid-layer", opacity: 0.9}).addTo(map);
  map.fitBounds(bounds.pad(0.05));
  const pad = L.marker(cellCentre(meta.charger), {
    icon: L.divIcon({className: "pad-marker", html: "pad", iconSize: [30, 20]}), zIndexOffset: -100,
    title: "charging pad"}).addTo(map);
  L.control.scale({imperial: false}).addTo(map);
  return {map, canvas, grid, gridVersion: -1, pad, btps: L.layerGroup().addTo(map),
          tracks: new Map(), ways: new Map(), markers: new Map()};
}

function drawGrid() {
  const map = state.map;
  if (!map || view.gridVersion === state.mapVersion) return;
  view.gridVersion = state.mapVersion;
  const cols = map.column_count, stride = map.cell_stride;
  const raw = Uint8Array.from(atob(map.data), c => c.charCodeAt(0));
  const rows = raw.length / (cols * stride);
  const code = (r, c) => raw[((rows - 1 - r) * cols + c) * stride];  // file rows run south first
  const canvas = view.canvas;
  canvas.width = cols; canvas.height = rows;
  const ctx = canvas.getContext("2d"), image = ctx.createImageData(cols, rows), px = image.data;
  let covered = 0;
  for (let r = 0; r < rows; r++) {
    for (let c = 0; c < cols; c++) {
      const k = code(r, c);
      let rgba;
      if (k === GRID_COVERED) { rgba = [255, 255, 255, 235]; covered++; }
      else if (k === GRID_OBSTACLE) rgba = [34, 34, 34, 255];
      else if (k === GRID_FREE) {
        const frontier = (r > 0 && code(r - 1, c) === GRID_UNKNOWN) || (r < rows - 1 && code(r + 1, c) === GRID_UNKNOWN)
          || (c > 0 && code(r, c - 1) === GRID_UNKNOWN) || (c < cols - 1 && code(r, c + 1) === GRID_UNKNOWN);
        rgba = frontier ? [41, 182, 246, 255] : [255, 217, 51, 255];
      } else rgba = [120, 120, 120, 90];
      px.set(rgba, (r * cols + c) * 4);
    }
  }
  ctx.putImageData(image, 0, 0);
  view.grid.setUrl(canvas.toDataURL());
  state.coveredOnMap = covered;
}

function arrowIcon(v, status) {
  const heading = v.pose ? headingDeg(v.pose) : 0;
  const lost = status && (status.phase === "lost" || !status.link_up);
  const fill = lost ? "#c62828" : v.colour;
  const label = `${v.sysid}${status ? " " + shortTask(status) : ""}`;
  const html = `<svg class="arrow" viewBox="-13 -13 26 26" style="transform: rotate(${heading.toFixed(0)}deg)">`
    + `<path d="M0,-11 L8,9 L0,4 L-8,9 Z" fill="${fill}" stroke="#000" stroke-width="1.2"/></svg>`
    + `<span class="label">${escapeHtml(label)}</span>`;
  return L.divIcon({className: "vehicle-marker", html, iconSize: [26, 26], iconAnchor: [13, 13]});
}

function shortTask(status) {
  if (status.phase === "lost") return "lost";
  if (status.phase === "done") return "parked";
  if (status.phase === "charging") return "charging";
  return TASKS[status.task] || status.task || status.phase;
}

function drawVehicles() {
  for (const v of state.vehicles.values()) {
    if (!v.pose) continue;
    const p = v.pose.position, at = latLng(p.x, p.y), status = v.status;
    let marker = view.markers.get(v.sysid);
    if (!marker) {
      marker = L.marker(at, {icon: arrowIcon(v, status), zIndexOffset: 100, keyboard: false}).addTo(view.map);
      view.markers.set(v.sysid, marker);
    }
    marker.setLatLng(at);
    marker.setIcon(arrowIcon(v, status));
    const el = marker.getElement();
    if (el) {
      el.dataset.sysid = v.sysid;
      // Where it last arrived (each arrival is logged); the status may be a moment older.
      const cell = v.battery ? v.battery.cell : (status ? status.cell : null);
      el.dataset.cell = cell ? cell.join(",") : "";
    }
    let track = view.tracks.get(v.sysid);
    if (!track) {
      track = L.polyline([], {color: v.colour, weight: 2.5, opacity: 0.8}).addTo(view.map);
      view.tracks.set(v.sysid, track);
    }
    track.setLatLngs(v.track.map(([x, y]) => latLng(x, y)));
    let way = view.ways.get(v.sysid);
    if (!way) {
      way = L.polyline([], {color: v.colour, weight: 2, dashArray: "5 5", opacity: 0.95}).addTo(view.map);
      view.ways.set(v.sysid, way);
    }
    const cells = wayAhead(status, v.battery ? v.battery.cell : null);
    way.setLatLngs(cells.length ? [at, ...cells.map(cellCentre)] : []);
  }
  for (const [sysid, marker] of view.markers) {  // a seek back to before a vehicle showed
    if (!state.vehicles.get(sysid) || !state.vehicles.get(sysid).pose) {
      marker.remove(); view.markers.delete(sysid);
      view.tracks.get(sysid)?.setLatLngs([]); view.ways.get(sysid)?.setLatLngs([]);
    }
  }
  view.btps.clearLayers();
  for (const cell of state.btps) {
    L.circleMarker(cellCentre(cell), {radius: 5, color: "#7f0000", weight: 1, fillColor: "#d32f2f", fillOpacity: 0.9})
      .addTo(view.btps);
  }
}

// The planned way from where the vehicle last arrived: a status is written a few times a
// second, so the vehicle may have gone on along it since; a way it has left is not drawn.
function wayAhead(status, here) {
  const way = status && status.way ? status.way : [];
  if (!way.length || !here || !status.cell) return way;
  if (status.cell[0] === here[0] && status.cell[1] === here[1]) return way;
  const k = way.findIndex(c => c[0] === here[0] && c[1] === here[1]);
  return k >= 0 ? way.slice(k + 1) : [];
}

function clock(seconds) {
  const s = Math.max(0, Math.floor(seconds)), h = Math.floor(s / 3600), m = Math.floor(s / 60) % 60;
  const ss = String(s % 60).padStart(2, "0");
  return h ? `${h}:${String(m).padStart(2, "0")}:${ss}` : `${m}:${ss}`;
}

function escapeHtml(text) {
  return String(text).replace(/[&<>"']/g, c => ({"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;"}[c]));
}

function metres(value) { return value == null ? "-" : `${Math.round(value)} m`; }

function coverage() {
  const p = state.progress;
  if (p) return {covered: p.covered, free: p.free, pct: p.pct};
  const free = (state.meta && state.meta.free_cells) || 0, covered = state.coveredOnMap || 0;
  return {covered, free, pct: free ? 100 * Math.min(covered, free) / free : 0};
}

function drawPanel() {
  const meta = state.meta, p = state.progress, c = coverage();
  document.getElementById("title").textContent = meta ? meta.mission : "waiting for the mission";
  document.getElementById("coverage-bar").style.width = `${c.pct.toFixed(1)}%`;
  document.getElementById("coverage").textContent = `${c.pct.toFixed(1)} % covered (${c.covered} / ${c.free} cells)`;
  const speed = p && p.speedup ? (p.speedup === 1 ? " (real time)" : ` (${p.speedup}x real time)`) : "";
  document.getElementById("clock").textContent = `mission time ${clock(state.t)}${config.mode === "live" ? speed : ""}`;
  let text = p ? p.state : "-";
  if (p && p.time_left_s != null) text = `covering: ~${clock(p.time_left_s)} left at this pace`;
  document.getElementById("state").textContent = text;

  const rows = [];
  for (const v of [...state.vehicles.values()].sort((a, b) => a.sysid - b.sysid)) {
    const s = v.status, b = v.battery;
    const battery = s && s.battery_pct != null ? s.battery_pct : (b ? b.battery_pct : null);
    const colour = battery == null ? "#999" : battery < 25 ? "#c62828" : battery < 50 ? "#f9a825" : "#2e7d32";
    const activity = s ? s.activity : (b ? b.mode : "-");
    const task = s ? (TASKS[s.task] || s.task || "-") : "";
    const link = !s ? "-" : s.link_up
      ? `<span class="up">up</span>${s.heard_s_ago >= 2 ? `<small>heard ${s.heard_s_ago.toFixed(0)} s ago</small>` : ""}`
      : `<span class="lost">lost</span>${s.heard_s_ago != null ? `<small>${s.heard_s_ago.toFixed(0)} s silent</small>` : ""}`;
    const rejected = s && s.rejected_frames ? `<small>${s.rejected_frames} frames refused</small>` : "";
    rows.push(`<tr data-sysid="${v.sysid}"><td><span class="dot" style="background:${v.colour}"></span>${v.sysid}`
      + `<small>${escapeHtml(s ? s.kind : "")}</small></td>`
      + `<td>${escapeHtml(activity)}<small>planner: ${escapeHtml(task)}</small></td>`
      + `<td>${battery == null ? "-" : battery.toFixed(0) + " %"}<div class="batt"><div style="width:${battery || 0}%;background:${colour}"></div></div>`
      + `${s && s.charges ? `<small>${s.charges} charge${s.charges > 1 ? "s" : ""}</small>` : ""}</td>`
      + `<td>${s ? metres(s.range_m) : "-"}<small>home ${s ? metres(s.home_m) : "-"}</small></td>`
      + `<td>${link}${rejected}</td></tr>`);
  }
  document.querySelector("#vehicles tbody").innerHTML = rows.join("");

  const statuses = [...state.vehicles.values()].map(v => v.status).filter(Boolean);
  const charging = statuses.filter(s => s.phase === "charging" || s.task === "charging");
  const coming = statuses.filter(s => s.task === "returning" && s.phase !== "charging")
    .sort((a, b) => (a.home_m ?? 1e9) - (b.home_m ?? 1e9));
  const padText = [
    charging.length ? "charging: " + charging.map(s => `${s.sysid} (${s.battery_pct?.toFixed(0) ?? "-"} %)`).join(", ") : "charging: none",
    coming.length ? "on the way: " + coming.map(s => `${s.sysid} (${metres(s.home_m)} away)`).join(", ") : "",
  ].filter(Boolean).join(" · ");
  document.getElementById("pad").textContent = padText;

  const shown = state.events.slice(-MAX_EVENTS_SHOWN).reverse();
  document.getElementById("events").innerHTML = shown.map(e =>
    `<li class="${LEVELS[e.level] || "info"}"><time>${clock(e.t_s ?? 0)}</time>${escapeHtml(e.message)}</li>`).join("");

  const body = document.body.dataset;  // what the page shows, for tests and scripts
  body.t = state.t.toFixed(3);
  body.progressT = p ? String(p.t_s) : "";
  body.coveragePct = c.pct.toFixed(3);
  body.covered = String(c.covered);
  body.vehicles = String(view ? view.markers.size : 0);
  body.events = String(state.events.length);
}

function draw() {
  drawPending = false;
  if (state.meta && !view) view = makeView();
  if (view) { drawGrid(); drawVehicles(); }
  drawPanel();
  document.body.dataset.ready = state.meta ? "yes" : "no";
}

function requestDraw() {
  if (!drawPending) { drawPending = true; requestAnimationFrame(draw); }
}

// -- live ----------------------------------------------------------------------------

function connect() {
  const source = document.getElementById("source");
  const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`);
  ws.binaryType = "arraybuffer";
  const decoder = new TextDecoder();
  let first = true;
  ws.onopen = () => { source.textContent = "LIVE"; source.className = "badge live"; };
  ws.onmessage = event => {
    const message = JSON.parse(decoder.decode(event.data));
    if (first) { state = emptyState(); if (view) view.gridVersion = -1; first = false; }  // a new connection sends it all
    for (const record of message.records) apply(record);
    if (config.mode === "replay") startReplay(message.records);
    else requestDraw();
  };
  ws.onclose = () => {
    if (config.mode === "replay") return;
    const ended = state.progress && /parked/.test(state.progress.state);
    source.textContent = ended ? "ENDED" : "station gone: retrying"; source.className = "badge down";
    setTimeout(connect, 2000);
  };
}

// -- replay --------------------------------------------------------------------------

let replay = null;

function startReplay(records) {
  const end = records.reduce((t, r) => Math.max(t, r.t), 0);
  replay = {records, index: records.length, t: end, playing: false, last: null};
  document.getElementById("replay").hidden = false;
  const slider = document.getElementById("slider");
  slider.max = end.toFixed(1);
  slider.value = end.toFixed(1);
  document.getElementById("source").textContent = "REPLAY";
  document.getElementById("source").className = "badge replay";
  slider.addEventListener("input", () => { pause(); seek(Number(slider.value)); });
  document.getElementById("play").addEventListener("click", () => replay.playing ? pause() : play());
  requestDraw();
}

function seek(t) {
  if (t < replay.t) {  // back in time: from the start again
    state = emptyState();
    if (view) view.gridVersion = -1;
    replay.index = 0;
  }
  const records = replay.records;
  while (replay.index < records.length && records[replay.index].t <= t) apply(records[replay.index++]);
  replay.t = t;
  state.t = t;
  document.getElementById("slider").value = t.toFixed(1);
  requestDraw();
}

function play() {
  if (replay.t >= Number(document.getElementById("slider").max)) seek(0);
  replay.playing = true; replay.last = null;
  document.getElementById("play").innerHTML = "&#10074;&#10074;";
  requestAnimationFrame(tick);
}

function pause() {
  replay.playing = false;
  document.getElementById("play").innerHTML = "&#9654;";
}

function tick(now) {
  if (!replay.playing) return;
  const rate = Number(document.getElementById("rate").value);
  if (replay.last != null) {
    const end = Number(document.getElementById("slider").max);
    const t = Math.min(end, replay.t + (now - replay.last) / 1000 * rate);
    seek(t);
    if (t >= end) { pause(); return; }
  }
  replay.last = now;
  requestAnimationFrame(tick);
}

// -- start ---------------------------------------------------------------------------

fetch("config.json").then(r => r.json()).then(c => {
  config = c;
  document.title = `${c.title} - staying-alive-gcs`;
  connect();
});
