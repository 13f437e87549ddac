// The plotter's page: events from /ws, requests to /api/... (see app.py).
// Drawing is in millimetres with y up, as the plotter counts: an SVG point
// (x, -y) in a viewBox over the work area.
"use strict";

const $ = (id) => document.getElementById(id);
const NS = "http://www.w3.org/2000/svg";
let area = [0, 200, 0, 200];
let board = { state: "UNKNOWN", connected: false };
let job = null;
let checkedId = null;

function show(text, error) {
  const m = $("message");
  m.textContent = text;
  m.className = error ? "error" : "";
}

async function api(path, body) {
  const init = { method: "POST", headers: { "X-Plotter": "1" } };
  if (body instanceof FormData) init.body = body;
  else { init.body = JSON.stringify(body || {}); init.headers["Content-Type"] = "application/json"; }
  let reply;
  try {
    const response = await fetch(path, init);
    reply = await response.json();
    if (!response.ok) throw new Error(reply.error || response.statusText);
  } catch (err) {
    show(err.message, true);
    throw err;
  }
  return reply;
}

// --- the sheet -------------------------------------------------------------------
function setArea(a) {
  area = a;
  const [x0, x1, y0, y1] = a, m = 5;
  const svg = $("area");
  svg.setAttribute("viewBox", `${x0 - m} ${-(y1 + m)} ${x1 - x0 + 2 * m} ${y1 - y0 + 2 * m}`);
  const border = $("border");
  border.setAttribute("x", x0); border.setAttribute("y", -y1);
  border.setAttribute("width", x1 - x0); border.setAttribute("height", y1 - y0);
  const grid = $("grid");
  grid.replaceChildren();
  for (let x = Math.ceil(x0 / 10) * 10; x <= x1; x += 10) grid.appendChild(line(x, -y0, x, -y1));
  for (let y = Math.ceil(y0 / 10) * 10; y <= y1; y += 10) grid.appendChild(line(x0, -y, x1, -y));
}

function line(xa, ya, xb, yb) {
  const l = document.createElementNS(NS, "line");
  l.setAttribute("x1", xa); l.setAttribute("y1", ya); l.setAttribute("x2", xb); l.setAttribute("y2", yb);
  return l;
}

function setInk(points) {            // a line list: x0 y0 x1 y1 per segment
  const parts = [];
  for (let k = 0; k + 3 < points.length; k += 4) {
    parts.push(`M${points[k]} ${-points[k + 1]}L${points[k + 2]} ${-points[k + 3]}`);
  }
  $("ink").setAttribute("d", parts.join(""));
}

function setPlanned(points) {
  const pairs = [];
  for (let k = 0; k + 1 < points.length; k += 2) pairs.push(`${points[k]},${-points[k + 1]}`);
  $("planned").setAttribute("points", pairs.join(" "));
}

function polylines(g, lines, colour) {
  for (const pts of lines) {
    const p = document.createElementNS(NS, "polyline");
    p.setAttribute("points", pts.map(([x, y]) => `${x},${-y}`).join(" "));
    if (colour) p.style.stroke = colour;
    g.appendChild(p);
  }
}

// The plan of a checked file (motion/preview.py): each pen in its colour, the pen-up travel
// dashed, and its figures; without one, the pen-down paths.
function setPreview(lines, plan) {
  $("preview").replaceChildren();
  $("travel").replaceChildren();
  $("pens").replaceChildren();
  $("plan-summary").textContent = plan ? plan.summary : "";
  if (!plan) { polylines($("preview"), lines); return; }
  plan.layers.forEach((layer, k) => {
    polylines($("preview"), layer.lines, layer.colour);
    const li = document.createElement("li");
    const swatch = document.createElement("span");
    swatch.className = "swatch";
    swatch.style.background = layer.colour;
    li.append(swatch, ` ${k + 1}: ${layer.name}, ${layer.length_mm.toFixed(0)} mm`);
    $("pens").appendChild(li);
  });
  polylines($("travel"), plan.travel);
}

// --- state and job ------------------------------------------------------------------
function setState(s) {
  board = s;
  $("state").textContent = s.state;
  $("last-error").textContent = s.connected ? (s.last_error || "") : `not connected: ${s.last_error || ""}`;
  if (s.x_mm !== undefined) {
    $("x").textContent = s.x_mm.toFixed(3);
    $("y").textContent = s.y_mm.toFixed(3);
    $("pen-state").textContent = s.pen_down ? "down" : "up";
    const pen = $("pen");
    pen.setAttribute("cx", s.x_mm); pen.setAttribute("cy", -s.y_mm);
    pen.setAttribute("class", s.pen_down ? "down" : "");
  }
  $("pen-change").hidden = s.state !== "PEN_CHANGE";
  if (s.state === "PEN_CHANGE") {
    $("next-pen").textContent = s.next_pen;
    $("next-pen-swatch").style.background = s.next_pen_colour || "transparent";
  }
  const sensors = s.sensors !== undefined && s.sensors !== null;
  $("follow-box").hidden = !sensors;
  if (sensors) {
    $("sensors").textContent = [0, 1, 2].map((i) => (s.sensors >> i) & 1 ? "●" : "○").join("");
    $("follow-state").textContent = s.follow_state;
  }
  enable();
}

function clock(seconds) {
  const s = Math.round(Math.max(seconds, 0));
  if (s < 60) return `${s} s`;
  const m = Math.floor(s / 60);
  return `${m}:${String(s % 60).padStart(2, "0")}`;
}

function setJob(j) {
  if (j.status === "sending") $("job-count").textContent = String(Number($("job-count").textContent) + 1);
  job = j;
  $("job-name").textContent = j.name || "–";
  $("job-status").textContent = j.jobs_ahead ? `waiting (${j.jobs_ahead} ahead)` : (j.status || "");
  $("job-progress").value = j.progress || 0;
  $("job-percent").textContent = `${Math.round((j.progress || 0) * 100)}%`;
  $("job-left").textContent = j.status === "running" ? clock(j.seconds_left || 0) : "–";
  $("job-line").textContent = j.line || "–";
  $("job-follow").hidden = j.steps === undefined;
  if (j.steps !== undefined) {
    $("job-steps").textContent = String(j.steps);
    $("job-length").textContent = j.length_mm.toFixed(1);
  }
  if (j.status === "succeeded") show(`${j.name}: ${j.message && j.message !== "done" ? j.message : "done"}`, false);
  enable();
}

// The journal's recent jobs, each with a Resume button when it stopped part-way.
let jobs = [];
function setJobs(list) {
  jobs = list;
  const body = $("jobs").tBodies[0];
  body.replaceChildren();
  for (const j of list) {
    const tr = document.createElement("tr");
    tr.dataset.id = j.id;
    for (const t of [j.name, j.when.slice(5), `${j.completed}/${j.total}`, j.note ? `${j.state}: ${j.note}` : j.state]) {
      const td = document.createElement("td");
      td.textContent = t;
      tr.appendChild(td);
    }
    const td = document.createElement("td");
    if (j.resumable) {
      const b = document.createElement("button");
      b.textContent = "Resume";
      b.className = "resume-job";
      b.addEventListener("click", () => click("api/resume", { id: j.id }).catch(() => {}));
      td.appendChild(b);
    }
    tr.appendChild(td);
    body.appendChild(tr);
  }
  enable();
}

// The plotters of the ROS domain: a picker when there are several.
function setPlotters(namespaces, current) {
  const picker = $("plotter");
  picker.replaceChildren(...namespaces.map((ns) => new Option(ns, ns, ns === current, ns === current)));
  picker.hidden = namespaces.length < 2;
  $("namespace").hidden = !picker.hidden;
}

function busy() { return job && (job.status === "running" || job.status === "sending"); }

function enable() {
  const idle = board.connected && board.state === "IDLE" && !busy();
  for (const b of document.querySelectorAll(".jog")) b.disabled = !idle;
  $("cancel").disabled = !busy();
  $("follow").disabled = !idle;
  $("run").disabled = !checkedId;
  for (const b of document.querySelectorAll(".resume-job")) b.disabled = !idle;
}

// --- events ------------------------------------------------------------------------------
function connect() {
  const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`);
  ws.onopen = () => { $("connection").textContent = "connected"; $("connection").className = "ok"; };
  ws.onclose = () => {
    $("connection").textContent = "page disconnected: retrying"; $("connection").className = "bad";
    setTimeout(connect, 1000);
  };
  ws.onmessage = (ev) => {
    const e = JSON.parse(ev.data);
    if (e.type === "config") { setArea(e.area); $("namespace").textContent = e.namespace; }
    else if (e.type === "state") setState(e);
    else if (e.type === "ink") setInk(e.points);
    else if (e.type === "planned") setPlanned(e.points);
    else if (e.type === "job") setJob(e);
    else if (e.type === "jobs") setJobs(e.jobs);
    else if (e.type === "plotters") setPlotters(e.namespaces, e.current);
    else if (e.type === "message") show(e.text, e.level === "error");
  };
}

// --- controls --------------------------------------------------------------------------
async function check() {
  const file = $("file").files[0];
  checkedId = null;
  $("errors").replaceChildren();
  $("check-result").textContent = "";
  setPreview([], null);
  enable();
  if (!file) { show("choose a G-code or SVG file first", true); return; }
  const form = new FormData();
  form.append("file", file);
  form.append("width", $("svg-width").value);
  form.append("layers", $("svg-layers").value);
  if ($("svg-optimize").checked) form.append("optimize", "1");
  const r = await api("api/check", form);
  setPreview(r.preview, r.plan);
  if (r.ok) {
    checkedId = r.id;
    $("check-result").textContent = `${r.name}: ${r.lines} lines, fits the work area`;
    show(`${r.name} checked: see its plan, then press Run`, false);
  } else {
    for (const e of r.errors) {
      const li = document.createElement("li");
      li.textContent = e.line ? `line ${e.line}: ${e.message} ` : e.message;
      if (e.text) { const c = document.createElement("code"); c.textContent = e.text; li.appendChild(c); }
      $("errors").appendChild(li);
    }
    show(`${r.name}: cannot be drawn (see the errors)`, true);
  }
  enable();
}

async function click(path, body) {
  const r = await api(path, body);
  show(r.message, false);
}

$("file").addEventListener("change", () => check().catch(() => {}));
$("plotter").addEventListener("change", () => click("api/plotter", { namespace: $("plotter").value }).catch(() => {}));
$("check").addEventListener("click", () => check().catch(() => {}));
$("run").addEventListener("click", () => click("api/run", { id: checkedId }).catch(() => {}));
for (const [id, name] of [["hold", "hold"], ["resume", "resume"], ["cancel", "cancel"], ["estop", "estop"],
                          ["reset", "reset"], ["set-origin", "set_origin"], ["home", "home"]]) {
  $(id).addEventListener("click", () => click(`api/button/${name}`).catch(() => {}));
}
for (const b of document.querySelectorAll(".jog")) {
  b.addEventListener("click", () => {
    const step = Number($("jog-step").value);
    click("api/jog", { dx: Number(b.dataset.dx) * step, dy: Number(b.dataset.dy) * step }).catch(() => {});
  });
}
$("draw").addEventListener("click", () => click("api/draw", {
  shape: $("shape").value, x: Number($("shape-x").value), y: Number($("shape-y").value),
  size: Number($("shape-size").value), feed: Number($("shape-feed").value),
  clockwise: $("shape-cw").checked, reverse: $("shape-reverse").checked,
}).catch(() => {}));

$("follow").addEventListener("click", () => click("api/follow", {
  from_here: $("follow-here").checked, start_x_mm: Number($("follow-x").value),
  start_y_mm: Number($("follow-y").value), heading_deg: Number($("follow-heading").value),
  feed_mm_s: Number($("follow-feed").value), lost_mm: Number($("follow-lost").value),
  distance_mm: Number($("follow-distance").value),
}).catch(() => {}));

setArea(area);
enable();
connect();
