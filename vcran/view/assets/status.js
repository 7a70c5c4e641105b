"use strict";
// What each robot and station is at an instant: state, task, load, battery, last error; parts.
// Every value is a step series (vcran/view/model.py Steps) looked up by binary search.

const TASK_PALETTE = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
  "#17becf", "#bcbd22", "#393b79", "#ad494a", "#637939"];
const NO_TASK = "#c8c8c8";

// A task's colour: tasks are numbered in first-seen order, so a robot's consecutive tasks differ.
function taskColour(task) {
  return task < 0 ? NO_TASK : TASK_PALETTE[task % TASK_PALETTE.length];
}

function robotStatus(data, i, t) {
  const c = data.col;
  const state = stepValue(c, "states", i, t, 0);
  const task = stepValue(c, "current", i, t, -1);
  const load = stepValue(c, "loads", i, t, data.robots[i].carrying);
  const battery = stepValue(c, "batteries", i, t, NaN);
  const error = stepValue(c, "errors", i, t, -1);
  return {
    state: data.states[state],
    task,
    taskLabel: task >= 0 ? data.taskLabels[c["tasks.label"][task]] : "",
    load,
    battery: Number.isNaN(battery) ? null : battery,
    error: error >= 0 ? data.errorTexts[error] : "",
  };
}

// Production instants in (after, until] (vcran/view/parts.py productions).
function productions(station, after, until) {
  if (station.every <= 0 || until < station.start) return 0;
  const last = Math.floor((until - station.start) / station.every);
  const first = after < station.start ? 0 : Math.floor((after - station.start) / station.every) + 1;
  return Math.max(0, last - first + 1);
}

// Parts on station s at t: the count at its last transfer, plus what was produced since, up to its room.
function stationParts(data, s, t) {
  const c = data.col;
  const k = stepIndex(c, "parts", s, t);
  if (k < 0) return 0;
  const since = c["parts.t"][k];
  return c["parts.value"][k] + Math.min(c["parts.room"][k], productions(data.stations[s], since, t));
}

function formatTime(t) {
  if (!Number.isFinite(t)) return "—";
  const s = Math.max(0, t);
  const h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), sec = s % 60;
  const ss = sec.toFixed(1).padStart(4, "0");
  return h > 0 ? `${h}:${String(m).padStart(2, "0")}:${ss}` : `${m}:${ss}`;
}
