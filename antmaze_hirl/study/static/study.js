// The study page: draws the maze from above, sends clicks as subgoals, animates the walk, asks the questionnaire.
// Plain browser JavaScript (no build step). Every request carries the token from the page's URL.
"use strict";

const params = new URLSearchParams(window.location.search);
const token = params.get("token") || "";
let participant = params.get("participant");

const $ = (id) => document.getElementById(id);
const sections = ["picker", "intro", "task", "questionnaire", "done"];
const canvas = $("maze");
const ctx = canvas.getContext("2d");

let state = null;         // the server's last state
let busy = false;         // a request or an animation is running: clicks wait
let queryVisibleAt = 0;   // when the open query became clickable (after the animation), ms
let hover = null;         // mouse position in world metres
let questionnaireItems = null;

// What the busy indicator says while the page waits for the server (plain sentences, no internal names).
const BUSY = {
  start: "Please wait: the maze is loading...",
  next: "Please wait: the next maze is loading...",
  last: "Please wait: the computer is learning from your points and testing itself on new mazes...",
  label: "The robot is walking...",
};

// Protocol refusals (HTTP 409) become instructions; what the server said stays in the console for the experimenter.
const WAIT = {
  start: "Please wait, the maze is loading.",
  next: "Please wait, the next maze is loading.",
  label: "Please wait for the robot to stop, then click again.",
  questionnaire: "Please wait, the page is catching up.",
  pause: "Please wait, the page is catching up.",
};

class StudyError extends Error {
  constructor(status, detail) {
    super(detail);
    this.status = status;
    this.detail = detail;
  }
}

function plainMessage(error, action) {
  console.warn(`study ${action}:`, error);
  if (!(error instanceof StudyError)) {
    return "The connection to the study was lost. Check the network and try again, or call the experimenter.";
  }
  if (error.status === 403) { return "This link does not work: please ask the experimenter for the study link."; }
  if (error.status === 404) { return "This participant is not part of the study: please ask the experimenter."; }
  if (error.status === 409 && /paused/.test(error.detail)) { return "The study is paused: press P to continue."; }
  if (error.status === 409 && action === "load") {
    return "Your session cannot go on from here: please call the experimenter.";
  }
  if (error.status === 409) { return WAIT[action] || "Please wait, the page is catching up."; }
  if (error.status === 503) {
    return "The study could not save your last step, so it did not count: please call the experimenter.";
  }
  return "That did not work. Please try again; if it happens again, call the experimenter.";
}

// A wait over a second shows how long it has lasted, so the page never looks stuck.
let busyTimer = null;
function setBusy(text) {
  clearInterval(busyTimer);
  busyTimer = null;
  $("busy").hidden = !text;
  $("busy-text").textContent = text || "";
  if (text) {
    const started = performance.now();
    busyTimer = setInterval(() => {
      const seconds = Math.floor((performance.now() - started) / 1000);
      if (seconds >= 1) { $("busy-text").textContent = `${text} (${seconds} s)`; }
    }, 250);
  }
}

// The wait after a maze: without background updates the last maze of a part also waits for the learner's update
// and final test (with them, the server closes the part at once and finishes those after).
function nextBusyText() {
  return state && state.episode && state.episode.number >= state.episode.of ? BUSY.last : BUSY.next;
}

let shownMaze = null;  // the maze the status line speaks of (a new maze gets a fresh status)

// After a rated part's last maze the learner's last update and test may take a while (without background updates):
// the questionnaire is shown at once and answered meanwhile; this is that "next" request, which the submit awaits.
let closing = null;

function lastMazeOfRatedPart(current) {
  return Boolean(current && current.trial && !current.trial.practice && current.episode
    && current.episode.number >= current.episode.of);
}

// The server said no: tell the participant what to do, then show what the server has now.
async function refused(error, action) {
  const message = plainMessage(error, action);
  setError(message);
  if (error instanceof StudyError && error.status === 409 && action !== "load") {
    try {
      state = await api(participantPath("state"));
      await render();
      if (!/paused/.test(error.detail)) { setError(""); }  // the page is in step again
    } catch (again) {
      setError(plainMessage(again, "load"));
    }
  }
}

async function api(path, body) {
  const options = { headers: { "X-Study-Token": token } };
  if (body !== undefined) {
    options.method = "POST";
    options.headers["Content-Type"] = "application/json";
    options.body = JSON.stringify(body);
  }
  const response = await fetch(path, options);
  const data = await response.json().catch(() => ({ error: `HTTP ${response.status}` }));
  if (!response.ok) {
    throw new StudyError(response.status, data.error || `HTTP ${response.status}`);
  }
  return data;
}

function participantPath(suffix) {
  return `/api/participants/${encodeURIComponent(participant)}/${suffix}`;
}

function show(name) {
  for (const section of sections) {
    $(section).hidden = section !== name;
  }
}

function setError(message) {
  $("error").textContent = message || "";
}

// ---------------------------------------------------------------------------------- geometry
function scaleOf(maze) {
  const width = maze.high[0] - maze.low[0];
  const height = maze.high[1] - maze.low[1];
  return Math.min(canvas.width / width, canvas.height / height);
}

function toCanvas(maze, xy) {
  const s = scaleOf(maze);
  return [(xy[0] - maze.low[0]) * s, (maze.high[1] - xy[1]) * s];
}

function toWorld(maze, px, py) {
  const s = scaleOf(maze);
  return [maze.low[0] + px / s, maze.high[1] - py / s];
}

function insideBounds(maze, xy) {
  const [low, high] = maze.bounds;
  return xy[0] >= low[0] && xy[0] <= high[0] && xy[1] >= low[1] && xy[1] <= high[1];
}

// Why a click cannot be a subgoal (shown, and nothing is sent), or null when it can.
function refusalOf(xy) {
  const maze = state.maze;
  if (!insideBounds(maze, xy)) { return "That point is outside the maze: click inside it."; }
  const col = Math.floor((xy[0] - maze.low[0]) / maze.scale);
  const row = Math.floor((maze.high[1] - xy[1]) / maze.scale);
  if (maze.walls[row] && maze.walls[row][col]) { return "That is a wall: click on the white floor."; }
  const distance = Math.hypot(xy[0] - state.agent[0], xy[1] - state.agent[1]);
  // A click on the dashed line counts as inside: 3 screen pixels of slack (the line is drawn 2 px wide).
  const slack = (3 * canvas.width) / (canvas.getBoundingClientRect().width * scaleOf(maze));
  if (distance > state.subgoal_reach_m + slack) { return "Too far: click inside the dashed circle."; }
  return null;
}

// ----------------------------------------------------------------------------------- drawing
function drawDisc(maze, xy, radiusMetres, colour, minPixels) {
  const [x, y] = toCanvas(maze, xy);
  ctx.beginPath();
  ctx.arc(x, y, Math.max(radiusMetres * scaleOf(maze), minPixels), 0, 2 * Math.PI);
  ctx.fillStyle = colour;
  ctx.fill();
}

function drawScene(trail, agent) {
  const maze = state.maze;
  const s = scaleOf(maze);
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  ctx.fillStyle = "#5a5a5a";
  maze.walls.forEach((row, r) => row.forEach((wall, c) => {
    if (wall) {
      ctx.fillRect(c * maze.scale * s, r * maze.scale * s, maze.scale * s + 0.5, maze.scale * s + 0.5);
    }
  }));
  // goal: its reach radius, at least a visible dot
  drawDisc(maze, state.goal, state.success_radius_m, "rgba(220,40,40,0.85)", 6);
  // trail
  if (trail.length > 1) {
    ctx.beginPath();
    trail.forEach((p, i) => {
      const [x, y] = toCanvas(maze, p);
      if (i === 0) { ctx.moveTo(x, y); } else { ctx.lineTo(x, y); }
    });
    ctx.strokeStyle = "rgba(40,80,220,0.45)";
    ctx.lineWidth = 3;
    ctx.stroke();
  }
  // reach circle: "towards the target but not too far"
  const [ax, ay] = toCanvas(maze, agent);
  ctx.beginPath();
  ctx.setLineDash([8, 6]);
  ctx.arc(ax, ay, state.subgoal_reach_m * s, 0, 2 * Math.PI);
  ctx.strokeStyle = "#2850dc";
  ctx.lineWidth = 2;
  ctx.stroke();
  ctx.setLineDash([]);
  drawDisc(maze, agent, 0.12 * maze.scale, "#2850dc", 7);
  if (state.learner_subgoal) {
    const [lx, ly] = toCanvas(maze, state.learner_subgoal);
    ctx.save();
    ctx.translate(lx, ly);
    ctx.rotate(Math.PI / 4);
    ctx.strokeStyle = "#f08c00";
    ctx.lineWidth = 3;
    ctx.strokeRect(-7, -7, 14, 14);
    ctx.restore();
  }
  if (hover && !busy && insideBounds(maze, hover)) {
    const [hx, hy] = toCanvas(maze, hover);
    ctx.beginPath();
    ctx.moveTo(ax, ay);
    ctx.lineTo(hx, hy);
    ctx.strokeStyle = "rgba(0,0,0,0.35)";
    ctx.lineWidth = 1;
    ctx.stroke();
    drawDisc(maze, hover, 0, "rgba(0,0,0,0.5)", 4);
  }
}

function draw() {
  if (state && state.phase === "label" && state.maze) {
    drawScene(state.trail, state.agent);
  }
}

// Replays what the low level did after a click: each walked path, point by point.
function animate(walked, startTrail) {
  return new Promise((resolve) => {
    const points = walked.flatMap((w) => w.path);
    if (points.length === 0) { resolve(); return; }
    const duration = Math.min(2000, 12 * points.length);
    const trail = startTrail.slice();
    const started = performance.now();
    let shown = 0;
    function frame(now) {
      const upTo = Math.min(points.length, Math.ceil(((now - started) / duration) * points.length));
      while (shown < upTo) { trail.push(points[shown]); shown += 1; }
      drawScene(trail, trail[trail.length - 1]);
      if (shown < points.length) { requestAnimationFrame(frame); } else { resolve(); }
    }
    requestAnimationFrame(frame);
  });
}

// Steps the learner walked on its own (gated methods) before this query or to the maze's end: replayed first.
async function replayWalk() {
  const walk = state.walk || [];
  if (walk.length === 0 || !state.maze) { return; }
  const walkedPoints = walk.reduce((n, w) => n + w.path.length - 1, 0);
  $("status").textContent = "The robot walks on its own...";
  await animate(walk, state.trail.slice(0, state.trail.length - walkedPoints));
}

function endMessage(end) {
  return end.success
    ? `Maze ${end.number}: goal reached!`
    : `Maze ${end.number}: the robot did not make it this time.`;
}

// ------------------------------------------------------------------------------------ render
function renderProgress() {
  const parts = [`Participant ${state.participant}`];
  if (state.trial) {
    parts.push(`${state.trial.label}: part ${state.trial.number} of ${state.trials}`);
    if (state.episode) {
      parts.push(`Maze ${Math.min(state.episode.number, state.episode.of)} of ${state.episode.of}`);
      parts.push(`Goals reached: ${state.successes}`);
      parts.push(`Points given: ${state.labels}`);
    }
  }
  $("progress").innerHTML = "";
  for (const text of parts) {
    const span = document.createElement("span");
    span.textContent = text;
    $("progress").appendChild(span);
  }
}

async function render() {
  const wasBusy = busy;
  busy = true;  // while the learner's own steps replay and the page moves on, clicks wait
  try {
    while (state.phase === "episode_over") {  // a maze walked without a question, or a reload after a maze's end
      if (state.episode_end && state.walk) {
        show("task");
        renderProgress();
        await replayWalk();
        $("status").textContent = endMessage(state.episode_end);
      }
      setBusy(nextBusyText());
      try {
        state = await api(participantPath("next"), {});
      } finally {
        setBusy(null);
      }
    }
    if (state.phase === "label" && state.walk && state.walk.length) {
      show("task");
      renderProgress();
      await replayWalk();
      $("status").textContent = "Your turn: click the next point.";
    }
  } finally {
    busy = wasBusy;
  }
  renderProgress();
  renderUnsaved();
  $("paused").hidden = !state.paused;
  if (state.phase === "intro") {
    $("intro-title").textContent = state.trial.practice
      ? "Practice: get to know the task"
      : `${state.trial.label} (part ${state.trial.number} of ${state.trials})`;
    $("intro-learner").hidden = !state.learner_shown;
    $("intro-length").textContent = lengthText(state);
    renderSummary();
    show("intro");
    $("start").disabled = false;
  } else if (state.phase === "label") {
    show("task");
    $("legend-learner").hidden = !state.learner_subgoal;
    const maze = state.episode ? `${state.trial.number}/${state.episode.number}` : null;
    if (state.query && state.query.executes === false) {
      $("status").textContent = "The robot did not make it. Where should it have gone from here?";
    } else if (maze !== shownMaze || !$("status").textContent) {
      $("status").textContent = "Your turn: click a point inside the dashed circle.";
    }
    shownMaze = maze;
    draw();
    queryVisibleAt = performance.now();
    refreshCamera();
  } else if (state.phase === "questionnaire") {
    await renderQuestionnaire();
    show("questionnaire");
  } else if (state.phase === "done") {
    show("done");
  }
}

// A finished part whose results the server could not write yet (a full disk): it keeps trying; the person should know.
// The box is an alert, which screen readers announce whenever its text is written: only a new text is written.
function renderUnsaved() {
  const unsaved = state.unsaved;
  const box = $("unsaved");
  box.hidden = !unsaved;
  let text = "";
  if (unsaved) {
    const parts = unsaved.parts.join(", ");
    const why = unsaved.error ? ` (${unsaved.error})` : "";
    text = unsaved.retrying
      ? `Not everything is saved yet: the results of ${parts} could not be written${why}, and the computer keeps `
        + "trying. You can go on, but please tell the experimenter."
      : `The results of ${parts} could not be saved${why}: please tell the experimenter.`;
  }
  if (box.textContent !== text) { box.textContent = text; }
}

// How many mazes this part has and about how long it and the rest take (the server's estimate).
function lengthText(current) {
  const length = current.length;
  if (!length) { return ""; }
  const mazes = current.trial.episodes === 1 ? "1 maze" : `${current.trial.episodes} mazes`;
  let text = `This part has ${mazes} and takes about ${length.part_minutes} min.`;
  if (length.parts_left > 1) {
    text += ` With the ${length.parts_left - 1} part(s) after it, about ${length.minutes_left} min are left in all.`;
  }
  return text;
}

// After the practice: how it went, in one sentence, before the first real part.
function renderSummary() {
  const last = state.last_trial;
  const box = $("summary");
  box.hidden = !(last && last.practice);
  if (box.hidden) { return; }
  const mazes = last.episodes === 1 ? "maze" : "mazes";
  const points = last.labels === 1 ? "point" : "points";
  box.textContent = `Practice finished: the robot reached the goal in ${last.successes} of ${last.episodes} ${mazes}, `
    + `and you gave ${last.labels} ${points}. Now the real parts begin; they work the same way.`;
}

function refreshCamera() {
  const img = $("camera");
  img.hidden = !state.camera;
  if (state.camera) {
    img.src = `${participantPath("frame.png")}?token=${encodeURIComponent(token)}&t=${Date.now()}`;
  }
}

async function renderQuestionnaire() {
  if (!questionnaireItems) {
    questionnaireItems = (await api("/api/questionnaire")).items;
  }
  $("questionnaire-title").textContent = `How was ${state.trial.label}?`;
  const container = $("items");
  container.innerHTML = "";
  for (const item of questionnaireItems) {
    const box = document.createElement("fieldset");
    box.className = "item";
    const legend = document.createElement("legend");
    legend.innerHTML = "";
    const title = document.createElement("h3");
    title.textContent = item.title;
    legend.appendChild(title);
    box.appendChild(legend);
    const question = document.createElement("p");
    question.textContent = item.question;
    box.appendChild(question);
    const scale = document.createElement("div");
    scale.className = "scale";
    const low = document.createElement("span");
    low.className = "anchor";
    low.textContent = item.low;
    scale.appendChild(low);
    for (let value = 1; value <= item.points; value += 1) {
      const label = document.createElement("label");
      const input = document.createElement("input");
      input.type = "radio";
      input.name = item.key;
      input.value = String(value);
      label.appendChild(input);
      label.appendChild(document.createTextNode(` ${value}`));
      scale.appendChild(label);
    }
    const high = document.createElement("span");
    high.className = "anchor";
    high.textContent = item.high;
    scale.appendChild(high);
    box.appendChild(scale);
    container.appendChild(box);
  }
  $("comment").value = "";
  $("form-error").textContent = "";
}

// ------------------------------------------------------------------------------------ events
canvas.addEventListener("mousemove", (event) => {
  if (!state || !state.maze) { return; }
  const rect = canvas.getBoundingClientRect();
  const px = (event.clientX - rect.left) * (canvas.width / rect.width);
  const py = (event.clientY - rect.top) * (canvas.height / rect.height);
  hover = toWorld(state.maze, px, py);
  if (!busy) { draw(); }
});

canvas.addEventListener("mouseleave", () => { hover = null; if (!busy) { draw(); } });

canvas.addEventListener("click", async (event) => {
  if (busy || !state || state.phase !== "label" || !state.query || state.paused) { return; }
  const rect = canvas.getBoundingClientRect();
  const px = (event.clientX - rect.left) * (canvas.width / rect.width);
  const py = (event.clientY - rect.top) * (canvas.height / rect.height);
  const xy = toWorld(state.maze, px, py);
  const refusal = refusalOf(xy);
  if (refusal) {
    $("status").textContent = refusal;  // refused here: nothing is sent, the point is not counted
    return;
  }
  busy = true;
  setError("");
  const responseSeconds = (performance.now() - queryVisibleAt) / 1000;
  const before = state;
  try {
    $("status").textContent = "Walking...";
    const result = await api(participantPath("label"), {
      query: state.query.id, x: xy[0], y: xy[1], response_seconds: responseSeconds,
    });
    // An episode's last click: the server updates the learner while the page animates the walk.
    const next = result.episode_end ? api(participantPath("next"), {}) : null;
    await animate(result.walked, before.trail);
    if (result.episode_end) {
      $("status").textContent = endMessage(result.episode_end);
    } else {
      $("status").textContent = result.walked.some((w) => w.reached) ? "Reached. Click the next point." : "Click the next point.";
    }
    if (next && lastMazeOfRatedPart(before)) {
      closing = next;
      closing.catch(() => {});  // answered at the questionnaire's submit
      state = { ...before, phase: "questionnaire" };
      await renderQuestionnaire();
      show("questionnaire");
      return;
    }
    if (next) {
      setBusy(nextBusyText());  // the next maze (and, after a part's last, the update), if not done during the walk
      try {
        state = await next;
      } catch (error) {
        busy = false;
        await refused(error, "next");
        return;
      } finally {
        setBusy(null);
      }
    } else {
      state = result.state;
    }
    await render();
  } catch (error) {
    busy = false;
    await refused(error, "label");
  } finally {
    busy = false;
  }
});

$("start").addEventListener("click", async () => {
  if ($("start").disabled) { return; }
  $("start").disabled = true;  // a double click sends one start
  setError("");
  setBusy(BUSY.start);
  try {
    state = await api(participantPath("start"), {});
    $("status").textContent = "Click a point inside the dashed circle.";
    setBusy(null);
    await render();
  } catch (error) {
    setBusy(null);
    await refused(error, "start");
  } finally {
    setBusy(null);
    $("start").disabled = false;
  }
});

$("tlx").addEventListener("submit", async (event) => {
  event.preventDefault();
  const ratings = {};
  const missing = [];
  for (const item of questionnaireItems) {
    const chosen = document.querySelector(`input[name="${item.key}"]:checked`);
    if (chosen) { ratings[item.key] = Number(chosen.value); } else { missing.push(item.title); }
  }
  if (missing.length) {
    $("form-error").textContent = `Please answer: ${missing.join(", ")}.`;
    return;
  }
  if (closing) {  // the last maze is still being saved: wait for it, counting the seconds
    setBusy(BUSY.last);
    try {
      state = await closing;
    } catch (error) {
      closing = null;
      setBusy(null);
      await refused(error, "next");
      return;
    }
    closing = null;
    setBusy(null);
  }
  try {
    state = await api(participantPath("questionnaire"), {
      trial: state.trial.number, ratings, comment: $("comment").value,
    });
    await render();
  } catch (error) {
    $("form-error").textContent = plainMessage(error, "questionnaire");
  }
});

document.addEventListener("keydown", async (event) => {
  if (!state || !participant || event.target.tagName === "TEXTAREA") { return; }
  if (event.key === "p" || event.key === "P") {
    event.preventDefault();
    try {
      const wasPaused = state.paused;
      state = await api(participantPath("pause"), { paused: !wasPaused });
      $("paused").hidden = !state.paused;
      if (wasPaused && state.phase === "label") { queryVisibleAt = performance.now(); }
    } catch (error) {
      setError(plainMessage(error, "pause"));
    }
  }
});

// ------------------------------------------------------------------------------------- start
async function choose() {
  const study = await api("/api/study");
  const list = $("participants");
  list.innerHTML = "";
  for (const p of study.participants) {
    const button = document.createElement("button");
    button.type = "button";
    button.textContent = p.id;
    button.addEventListener("click", () => {
      participant = p.id;
      params.set("participant", p.id);
      window.history.replaceState(null, "", `?${params.toString()}`);
      load();
    });
    list.appendChild(button);
  }
  show("picker");
}

async function load() {
  try {
    if (!participant) { await choose(); return; }
    state = await api(participantPath("state"));
    await render();
  } catch (error) {
    setError(plainMessage(error, "load"));
  }
}

load();
