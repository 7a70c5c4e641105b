"use strict";
// The page: the floor, the time controls and the panels, kept at one instant, the cursor.
//
// window.vcranView is the page's debug API (docs/view.md), which the tests drive: every function works
// once `await vcranView.ready` has resolved.
//   seek(t) -> milliseconds the redraw took       time() -> the cursor
//   poses(t) -> [{robot, x, y, theta}]            drawn() -> what the last draw put on the floor:
//                                                  [{robot, x, y, theta, px, py, fill, task, selected}]
//                                                  (px, py: CSS pixels from the floor canvas's top left)
//   toPixel(x, y) -> [px, py]                      status(robot) -> {state, taskLabel, load, battery, error}
//   parts(station) -> parts at the cursor          selectJob(id), selectRobot(id), clear()
//   selected() -> {job, robots: [ids]}             play(), pause(), setSpeed(x)
//   jobs() -> the jobs as the page has them        incidents() -> [{t, kind, robot, text}]

class App {
  constructor(data) {
    this.data = data;
    this.t = 0;
    this.fleet = new Fleet(data);
    this.selection = { robots: new Set(), paths: [], job: -1 };
    const $ = (id) => document.getElementById(id);
    this.heading();
    this.floor = new Floor($("floor"), data, this.fleet);
    this.floor.onChange = () => this.draw();
    $("floor").addEventListener("click", (e) => {
      if (this.floor.wasDrag()) return;
      const i = this.floor.hit(e.offsetX, e.offsetY);
      if (i >= 0) { this.panels.show("robots"); this.selectRobot(i); } else this.clear();
    });
    $("fit").addEventListener("click", () => { this.floor.fit(); this.draw(); });
    this.timeline = new Timeline({
      slider: $("slider"), play: $("play"), speed: $("speed"), time: $("time"), end: $("end"), strip: $("strip"),
    }, data, (t) => this.seek(t), (k) => this.jumpToIncident(k));
    this.panels = new Panels(document.body, data, this);
    window.addEventListener("resize", () => {
      this.floor.resize(); this.floor.fit(); this.timeline.resize(); this.panels.measure(); this.draw();
    });
    window.addEventListener("keydown", (e) => {
      if (e.target instanceof HTMLInputElement || e.target instanceof HTMLSelectElement) return;
      if (e.key === " ") { e.preventDefault(); this.timeline.toggle(); }
      if (e.key === "ArrowRight") this.seek(this.t + (e.shiftKey ? 10 : 1));
      if (e.key === "ArrowLeft") this.seek(this.t - (e.shiftKey ? 10 : 1));
    });
    this.seek(0);
  }

  heading() {
    const data = this.data, notes = document.getElementById("notes");
    document.title = `vcran view: ${data.title}`;
    document.getElementById("title").textContent = data.title;
    notes.replaceChildren(...data.notes.map((note) => element("li", {}, note)));
    notes.hidden = !data.notes.length;
  }

  // The run grew (a live page): new data in place of the old, the view, the selection and the cursor
  // kept, unless the cursor was at the end, where it stays.
  replaceData(data) {
    const atEnd = this.t >= this.data.end;
    const job = this.selection.job >= 0 ? this.data.jobs[this.selection.job].id : null;
    const robots = [...this.selection.robots].map((i) => this.data.robots[i].id);
    this.data = data;
    this.fleet = new Fleet(data);
    this.heading();
    this.floor.setData(data, this.fleet);
    this.timeline.setData(data);
    this.panels.clear();
    this.panels = new Panels(document.body, data, this);
    const k = job === null ? -1 : data.jobs.findIndex((j) => j.id === job);
    if (k >= 0) {
      this.selectJob(k, false);
    } else {
      const kept = robots.map((id) => data.robots.findIndex((r) => r.id === id)).filter((i) => i >= 0);
      this.selection = { robots: new Set(kept), paths: [], job: -1 };
    }
    this.seek(atEnd ? data.end : this.t);
  }

  // Move the cursor to t and redraw everything; returns how long the redraw took (ms).
  seek(t) {
    const start = performance.now();
    this.t = Math.min(Math.max(0, t), this.data.end);
    this.draw();
    return performance.now() - start;
  }

  draw() {
    this.floor.draw(this.t, this.selection);
    this.timeline.setTime(this.t);
    this.panels.update(this.t, this.selection.robots);
  }

  selectRobot(i) {
    this.selection = { robots: new Set([i]), paths: [], job: -1 };
    this.panels.showJob(-1);
    const row = document.querySelector(`#robots tr[data-robot="${CSS.escape(this.data.robots[i].id)}"]`);
    if (row) row.scrollIntoView({ block: "nearest" });
    this.draw();
  }

  // A job: its robots highlighted, its tasks listed, the path driven while they were current drawn;
  // the cursor moves to its first task's start when it is outside the job's life.
  selectJob(k, move = true) {
    const c = this.data.col, job = this.data.jobs[k];
    const paths = [];
    let first = Infinity, last = -Infinity;
    for (const task of job.tasks) {
      const a = c["tasks.started"][task], b = c["tasks.end"][task];
      if (Number.isNaN(a)) continue;
      paths.push(this.fleet.path(c["tasks.robot"][task], a, b));
      first = Math.min(first, a); last = Math.max(last, b);
    }
    this.selection = { robots: new Set(job.robots), paths, job: k };
    this.panels.showJob(k);
    if (move && Number.isFinite(first) && (this.t < first || this.t > last)) this.seek(first); else this.draw();
  }

  clear() {
    this.selection = { robots: new Set(), paths: [], job: -1 };
    this.panels.showJob(-1);
    this.draw();
  }

  jumpToIncident(k) {
    const robot = this.data.col["incidents.robot"][k];
    this.t = this.data.col["incidents.t"][k];
    if (robot >= 0) this.selectRobot(robot); else this.seek(this.t);
  }
}

function robotIndex(data, id) {
  const i = data.robots.findIndex((r) => r.id === id);
  if (i < 0) throw new Error(`no robot ${id}`);
  return i;
}

function debugApi(app) {
  const d = () => app.data;  // a live page replaces its data: always the current
  return {
    seek: (t) => app.seek(t),
    time: () => app.t,
    poses: (t) => d().robots.map((r, i) => { const [x, y, theta] = app.fleet.pose(i, t); return { robot: r.id, x, y, theta }; }),
    drawn: () => app.floor.drawn.map((e) => ({ ...e })),
    toPixel: (x, y) => app.floor.toPixel(x, y),
    status: (id) => robotStatus(d(), robotIndex(d(), id), app.t),
    parts: (id) => stationParts(d(), d().stations.findIndex((s) => s.id === id), app.t),
    selectJob: (id) => app.selectJob(d().jobs.findIndex((j) => j.id === id)),
    selectRobot: (id) => app.selectRobot(robotIndex(d(), id)),
    clear: () => app.clear(),
    selected: () => ({ job: app.selection.job >= 0 ? d().jobs[app.selection.job].id : null,
      robots: [...app.selection.robots].map((i) => d().robots[i].id) }),
    play: () => { if (!app.timeline.playing) app.timeline.toggle(); },
    pause: () => { if (app.timeline.playing) app.timeline.toggle(); },
    setSpeed: (x) => { app.timeline.speed = x; },
    jobs: () => d().jobs,
    incidents: () => {
      const c = d().col;
      return Array.from(c["incidents.t"], (t, k) => ({
        t, kind: d().incidentKinds[c["incidents.kind"][k]].kind,
        robot: c["incidents.robot"][k] >= 0 ? d().robots[c["incidents.robot"][k]].id : null,
        text: d().incidentTexts[k] }));
    },
    end: () => d().end,
  };
}

// Start: decode the embedded data, then build the page. A failure is shown, and logged as an error.
window.vcranView = {};
window.vcranView.ready = (async () => {
  try {
    const data = await decodeData(document.getElementById("vcran-data").textContent.trim());
    const app = new App(data);
    Object.assign(window.vcranView, debugApi(app));
    window.vcranView.app = app;
    if (typeof startLive === "function") startLive(app);  // live.js, on a page vcran live --view serves
  } catch (error) {
    document.getElementById("failure").hidden = false;
    document.getElementById("failure").textContent = `This page could not show the run: ${error.message}`;
    console.error(error);
    throw error;
  }
})();
