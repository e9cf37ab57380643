// A participant's page of `aaai study serve`: consent, instructions, the rounds, breaks, the end.
// The game runs on the server; this page sends keys and shows what the server sends.
"use strict";

const $ = (id) => document.getElementById(id);
const linkToken = new URLSearchParams(location.search).get("p") || "";
let socket = null;
let keys = new Set();
let study = null;          // the "joined" message: texts, progress, what is shown
let started = false;       // the participant pressed Start (a reconnect starts again by itself)
let pending = [];
let frameNo = 0;
let images = 1;

function send(message) {
  if (socket && socket.readyState === WebSocket.OPEN) socket.send(JSON.stringify(message));
}

function keyName(event) {
  return event.key.length === 1 ? event.key.toLowerCase() : event.key;
}

function setPhase(phase) {
  document.body.dataset.phase = phase;
}

function showScreen(title, text, feedback) {
  $("overlay").classList.remove("hidden");
  $("screen-title").textContent = title;
  $("screen-text").textContent = text || "";
  $("feedback").textContent = feedback || "";
  $("agree").hidden = true;
  $("start").hidden = true;
}

function connect() {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  socket = new WebSocket(`${scheme}://${location.host}/ws`);
  socket.binaryType = "blob";
  socket.onopen = () => send({type: "join", token: linkToken});
  socket.onmessage = (event) => {
    if (typeof event.data === "string") receive(JSON.parse(event.data));
    else image(event.data);
  };
  socket.onclose = () => {
    setPhase("disconnected");
    showScreen("Connection lost", "Reconnecting… your progress is kept.");
    setTimeout(connect, 1000);
  };
}

function receive(message) {
  if (message.type === "joined") {
    study = message;
    keys = new Set([...Object.keys(message.controls), ...message.start_keys]);
    images = message.show.map ? 2 : 1;
    $("map").hidden = !message.show.map;
    progress(message.progress);
    if (started) send({type: "start"});
    else if (!message.consented) consent();
    else instructions(message.resuming);
  } else if (message.type === "consented") {
    instructions(false);
  } else if (message.type === "error") {
    $("error").textContent = message.message;
    if (!study) { setPhase("refused"); showScreen("Sorry", message.message); }
  } else if (message.type === "frame") {
    frameNo = message.frame;
    pending = [];
    show(message);
  } else if (message.type === "status") {
    show(message);
  }
}

function consent() {
  setPhase("consent");
  showScreen("Before you start", study.texts.consent);
  $("agree").hidden = false;
  $("agree").focus();
}

function instructions(resuming) {
  setPhase("instructions");
  const back = resuming ? "Welcome back! You will carry on where you left off.\n\n" : "";
  const practice = study.practice && !resuming ? `\n\nFirst you will play ${study.practice} practice round${study.practice > 1 ? "s" : ""}.` : "";
  showScreen("How to play", back + study.texts.instructions + practice);
  $("start").hidden = false;
  $("start").focus();
}

$("agree").addEventListener("click", () => send({type: "consent"}));
$("start").addEventListener("click", () => {
  started = true;
  $("start").hidden = true;
  const root = document.documentElement;
  if (root.requestFullscreen) root.requestFullscreen().catch(() => {});
  send({type: "start"});
  send({type: "focus", focused: document.hasFocus()});
});

function progress(value) {
  $("progress").max = Math.max(1, value.total);
  $("progress").value = value.done;
}

function image(blob) {
  pending.push(blob);
  if (pending.length < images) return;
  const done = frameNo;
  let loaded = 0;
  const targets = [$("camera"), $("map")].slice(0, images);
  targets.forEach((img, i) => {
    const old = img.src;
    img.onload = () => {
      if (old.startsWith("blob:")) URL.revokeObjectURL(old);
      if (++loaded === images) send({type: "ack", frame: done});
    };
    img.src = URL.createObjectURL(pending[i]);
  });
}

let lastStatus = null;

function show(status) {
  lastStatus = status;
  setPhase(status.phase);
  progress(status.progress);
  const practice = status.kind === "practice";
  $("round").textContent = practice ? "Practice" :
    `Round ${Math.min(status.progress.done + 1, status.progress.total)} of ${status.progress.total}`;
  if (status.time_left !== undefined && status.time_left !== null) {
    $("clock").hidden = false;
    $("time-left").textContent = Number(status.time_left).toFixed(0);
  }
  const extra = [];
  if (status.pose) extra.push(`x ${status.pose.x.toFixed(1)} y ${status.pose.y.toFixed(1)} heading ${status.pose.yaw_deg.toFixed(0)}°`);
  if (status.trial) extra.push(`${status.trial.arena || status.trial.label} difficulty ${status.trial.difficulty} seed ${status.trial.seed}`);
  if (status.last) extra.push(`score ${Number(status.last.return).toFixed(2)} of ${Number(status.last.max_reward).toFixed(2)}`);
  $("extra").hidden = extra.length === 0;
  $("extra").textContent = extra.join(" · ");
  if (status.phase === "running") {
    $("overlay").classList.add("hidden");
  } else if (status.phase === "ready") {
    let title = practice ? "Practice round" : `Round ${status.progress.done + 1} of ${status.progress.total}`;
    let text = "";
    if (status.break) { title = "Time for a short break"; text = "Rest for a moment. "; }
    if (status.first_battery) text = "The practice is over. Now the real rounds begin. ";
    text += status.accepts_start ? "Press Space when you are ready." : "Get ready…";
    showScreen(title, text, status.feedback);
    // keys start a round a moment after the last one ended: say so then (the server ignores them before)
    if (!status.accepts_start) {
      setTimeout(() => lastStatus === status && show({...status, accepts_start: true}), 1100);
    }
  } else if (status.phase === "paused") {
    showScreen("Paused", "Press Space to go on.");
  } else if (status.phase === "loading") {
    showScreen("", "", status.feedback);
  } else if (status.phase === "finished") {
    started = false;
    showScreen("Thank you!", study ? study.texts.completion : status.message, status.feedback);
  } else if (status.phase === "abandoned" || status.phase === "error") {
    showScreen("Stopped", status.message + " Reload this page with your link to carry on.");
  }
}

document.addEventListener("keydown", (event) => {
  const key = keyName(event);
  if (!keys.has(key) || !started) return;
  event.preventDefault();
  if (!event.repeat) send({type: "key", key: key, down: true});
});

document.addEventListener("keyup", (event) => {
  const key = keyName(event);
  if (!keys.has(key) || !started) return;
  event.preventDefault();
  send({type: "key", key: key, down: false});
});

window.addEventListener("blur", () => send({type: "focus", focused: false}));
window.addEventListener("focus", () => send({type: "focus", focused: true}));
document.addEventListener("visibilitychange", () => send({type: "focus", focused: !document.hidden}));

connect();
