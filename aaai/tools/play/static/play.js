// The page of `aaai play`: keys and focus go to the server; frames and status come back.
// The simulation runs on the server at its own pace; this page only shows it.
"use strict";

const $ = (id) => document.getElementById(id);
let socket = null;
let keys = new Set();        // keys the server knows (from its hello)
let token = sessionStorage.getItem("aaai-token");
let player = sessionStorage.getItem("aaai-player");
let pending = [];            // the images of the frame being received: [camera, map]
let frameNo = 0;
let lastStatus = null;
let joined = false;
// On a network the server asks for the token of the link it printed (and keeps it in a cookie).
const linkToken = new URLSearchParams(location.search).get("token");

function keyName(event) {
  return event.key.length === 1 ? event.key.toLowerCase() : event.key;
}

function send(message) {
  if (socket && socket.readyState === WebSocket.OPEN) socket.send(JSON.stringify(message));
}

function connect() {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  const query = linkToken ? `?token=${encodeURIComponent(linkToken)}` : "";
  socket = new WebSocket(`${scheme}://${location.host}/ws${query}`);
  socket.binaryType = "blob";
  socket.onmessage = (event) => {
    if (typeof event.data === "string") receive(JSON.parse(event.data));
    else image(event.data);
  };
  socket.onclose = (event) => {
    joined = false;
    if (event.code === 4409) {  // another page (a reload, a duplicated tab) plays this player now
      showScreen("Playing in another page", "This player is played in another page now; close this one.");
      setPhase("disconnected");
      return;
    }
    showScreen("Connection lost", "Trying to reconnect… (the episode is paused)");
    setPhase("disconnected");
    setTimeout(connect, 1000);
  };
}

function join(name) {
  player = name;
  sessionStorage.setItem("aaai-player", name);
  send({type: "join", player: name, token: token});
}

function receive(message) {
  if (message.type === "hello") {
    keys = new Set(message.keys);
    if (message.player) join(message.player);
    else if (player) join(player);
    else askName();
  } else if (message.type === "joined") {
    joined = true;
    token = message.token;
    sessionStorage.setItem("aaai-token", token);
    $("error").textContent = "";
    send({type: "focus", focused: document.hasFocus()});
  } else if (message.type === "error") {
    $("error").textContent = message.message;
    if (!joined) {
      token = null;
      sessionStorage.removeItem("aaai-token");
      askName(message.message);
    }
  } else if (message.type === "frame") {
    frameNo = message.frame;
    pending = [];
    show(message);
  } else if (message.type === "status") {
    show(message);
  }
}

function image(blob) {
  pending.push(blob);
  if (pending.length < 2) return;
  const [camera, map] = pending;
  const done = frameNo;
  let loaded = 0;
  for (const [img, data] of [[$("camera"), camera], [$("map"), map]]) {
    const old = img.src;
    img.onload = () => {
      if (old.startsWith("blob:")) URL.revokeObjectURL(old);
      if (++loaded === 2) send({type: "ack", frame: done});
    };
    img.src = URL.createObjectURL(data);
  }
}

function askName(problem) {
  showScreen("Who is playing?", problem || "Type your name (letters, digits, - and _), then press Play.");
  const form = $("join");
  form.hidden = false;
  const field = $("player");
  field.value = field.value || new URLSearchParams(location.search).get("player") || "";
  field.focus();
}

$("join").addEventListener("submit", (event) => {
  event.preventDefault();
  $("join").hidden = true;
  join($("player").value.trim());
});

function showScreen(title, text) {
  $("overlay").classList.remove("hidden");
  $("screen-title").textContent = title;
  $("screen-text").textContent = text;
}

function hideScreen() {
  $("overlay").classList.add("hidden");
  $("join").hidden = true;
}

function setPhase(phase) {
  $("phase").textContent = phase;
  $("phase").dataset.phase = phase;
}

function describeLast(last) {
  if (!last) return "";
  const where = last.arena || `L${last.level} ${last.level_name}`;
  return `Last episode (${where}, difficulty ${last.difficulty}): return ${Number(last.return).toFixed(2)} ` +
         `of ${Number(last.max_reward).toFixed(2)}, ${last.outcome}, food eaten ${last.food_eaten}. `;
}

function show(status) {
  lastStatus = status;
  const episode = status.episode || {};
  if (episode.label) {
    $("level-label").textContent = episode.arena ? episode.arena : episode.label;
    $("level-title").textContent = episode.arena ? "" : episode.title;
    $("level-cell").textContent = `difficulty ${episode.difficulty} · seed ${episode.seed}`;
    $("task").textContent = episode.task;
    $("episode").textContent = `${episode.index} of ${episode.total}`;
  }
  if (status.time_left !== undefined) $("time-left").textContent = status.time_left.toFixed(1);
  if (status.food_eaten !== undefined) $("food").textContent = status.food_eaten;
  if (status.pose) {
    const pose = $("pose");
    pose.dataset.x = status.pose.x;
    pose.dataset.y = status.pose.y;
    pose.dataset.yaw = status.pose.yaw_deg;
    pose.textContent = `x ${status.pose.x.toFixed(1)} y ${status.pose.y.toFixed(1)} heading ${status.pose.yaw_deg.toFixed(0)}°`;
  }
  $("fps").textContent = status.fps;
  setPhase(status.phase);
  const last = describeLast(status.last);
  if (status.phase === "running") hideScreen();
  else if (status.phase === "ready") {
    const go = status.accepts_start ? "Press Space (or an arrow key) to start." : "Get ready…";
    showScreen(`Episode ${episode.index} of ${episode.total}: ${episode.arena || episode.label + " " + episode.title}`,
               `${last}${episode.task} ${go}`);
    if (!status.accepts_start) setTimeout(() => lastStatus === status && show(status), 300);
  } else if (status.phase === "paused") {
    showScreen("Paused", `${status.message}. Press Space to go on.`);
  } else if (status.phase === "finished") {
    showScreen("Thank you!", `${last}${status.message}.`);
  } else if (status.phase === "error" || status.phase === "abandoned") {
    showScreen("Stopped", status.message);
  } else if (status.phase === "loading") {
    showScreen("Loading…", last);
  }
}

document.addEventListener("keydown", (event) => {
  if (event.target instanceof HTMLInputElement) return;
  const key = keyName(event);
  if (!keys.has(key)) return;   // keys that do nothing stay the browser's
  event.preventDefault();
  if (!event.repeat) send({type: "key", key: key, down: true});
});

document.addEventListener("keyup", (event) => {
  if (event.target instanceof HTMLInputElement) return;
  const key = keyName(event);
  if (!keys.has(key)) return;
  event.preventDefault();
  send({type: "key", key: key, down: false});
});

window.addEventListener("blur", () => send({type: "focus", focused: false}));
window.addEventListener("focus", () => send({type: "focus", focused: true}));
document.addEventListener("visibilitychange", () => send({type: "focus", focused: !document.hidden}));

connect();
