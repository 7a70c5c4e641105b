"use strict";
// The side panels: every robot's state, task, load, battery and last error at the cursor; the jobs with
// their lead times (a click selects one: its robot, tasks and path); the incidents as a list; the run.

const INCIDENT_WINDOW = 300;  // incident rows listed around the cursor (the strip shows them all)

function element(tag, attrs = {}, text = "") {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (text) e.textContent = text;
  return e;
}

function seconds(v) { return v === null || v === undefined || Number.isNaN(v) ? "—" : `${v.toFixed(1)} s`; }

class Panels {
  constructor(root, data, app) {
    this.data = data;
    this.app = app;
    this.root = root;
    this.cells = [];
    this.buildTabs();
    this.buildRobots();
    this.buildJobs();
    this.buildIncidents();
    this.buildAbout();
    this.show(app.panels ? app.panels.current : data.jobs.length ? "jobs" : "robots");
  }

  // Empty what the constructor filled: a live page builds the panels anew as the run grows.
  clear() {
    for (const selector of ["#tabs", "#robots tbody", "#jobs tbody", "#incidents", "#panel-about", "#job-detail"]) {
      this.root.querySelector(selector).replaceChildren();
    }
  }

  buildTabs() {
    const d = this.data, tabs = this.root.querySelector("#tabs");
    const names = [["robots", `Robots (${d.robots.length})`], ["jobs", `Jobs (${d.jobs.length})`],
      ["incidents", `Incidents (${d.col["incidents.t"].length})`], ["about", "Run"]];
    this.tabs = {};
    for (const [name, label] of names) {
      const b = element("button", { "data-tab": name, role: "tab" }, label);
      b.addEventListener("click", () => this.show(name));
      tabs.appendChild(b);
      this.tabs[name] = b;
    }
  }

  show(name) {
    this.current = name;
    for (const [n, b] of Object.entries(this.tabs)) {
      b.classList.toggle("active", n === name);
      this.root.querySelector(`#panel-${n}`).hidden = n !== name;
    }
    if (name === "incidents") this.listIncidents(this.app.t, true);
    if (name === "robots") this.measure();
    if (name === "robots" && this.selected) this.update(this.t, this.selected);
  }

  // Which rows of the robot table are in sight: its scroll offset, height and row height.
  measure() {
    const box = this.root.querySelector("#panel-robots"), first = this.cells.length ? this.cells[0].row : null;
    this.sight = { top: box.scrollTop, height: box.clientHeight || window.innerHeight,
      row: first && first.offsetHeight > 0 ? first.offsetHeight : 20 };
  }

  buildRobots() {
    const body = this.root.querySelector("#robots tbody");
    this.sight = { top: 0, height: window.innerHeight, row: 20 };
    const box = this.root.querySelector("#panel-robots");
    box.onscroll = () => { this.measure(); if (this.selected) this.update(this.t, this.selected); };
    this.data.robots.forEach((r, i) => {
      const row = element("tr", { "data-robot": r.id });
      const cells = [element("td", {}, r.id)];
      for (let k = 0; k < 5; k++) cells.push(element("td"));
      cells.forEach((c) => row.appendChild(c));
      row.addEventListener("click", () => this.app.selectRobot(i));
      body.appendChild(row);
      this.cells.push({ row, cells, last: [] });
    });
  }

  // Refresh the robot table at t: only while it is shown, only the rows in sight (a thousand rows'
  // layout was most of a scrub's time), only the cells whose text changed.
  update(t, selected) {
    this.t = t;
    this.selected = selected;
    if (this.current === "incidents") this.listIncidents(t, false);
    if (this.current !== "robots") return;
    const d = this.data, sight = this.sight;  // measured when shown and scrolled: reading the layout
    const from = Math.max(0, Math.floor(sight.top / sight.row) - 5);  // here would force it at every scrub
    const to = Math.min(d.robots.length, from + Math.ceil(sight.height / sight.row) + 10);
    for (let i = from; i < to; i++) {
      const s = robotStatus(d, i, t), entry = this.cells[i];
      const texts = [s.state, s.taskLabel || "—", `${s.load}/${d.robots[i].capacity}`,
        s.battery === null ? "—" : `${s.battery.toFixed(0)}%`, s.error || "—"];
      for (let k = 0; k < texts.length; k++) {
        if (entry.last[k] !== texts[k]) {
          entry.cells[k + 1].textContent = texts[k];
          if (k === 4) entry.cells[k + 1].title = texts[k];  // the whole error, where the cell cuts it
          entry.last[k] = texts[k];
        }
      }
      const colour = taskColour(s.task);
      if (entry.colour !== colour) { entry.cells[2].style.borderLeft = `6px solid ${colour}`; entry.colour = colour; }
      const on = selected.has(i);
      if (entry.on !== on) { entry.row.classList.toggle("selected", on); entry.on = on; }
    }
  }

  buildJobs() {
    const d = this.data, body = this.root.querySelector("#jobs tbody");
    this.jobRows = d.jobs.map((j, k) => {
      const robots = j.robots.map((i) => d.robots[i].id).join(", ") || "—";
      const row = element("tr", { "data-job": j.id, class: `job-${j.status}` });
      for (const text of [j.id, j.status, robots, formatTime(j.arrived), seconds(j.lead)]) {
        row.appendChild(element("td", {}, text));
      }
      row.addEventListener("click", () => this.app.selectJob(k));
      body.appendChild(row);
      return row;
    });
    this.root.querySelectorAll("#jobs th[data-sort]").forEach((th) => {
      th.onclick = () => this.sortJobs(th.dataset.sort);  // one handler, whichever Panels is current
    });
    this.root.querySelector("#panel-jobs .empty").hidden = d.jobs.length > 0;
  }

  sortJobs(key) {
    const d = this.data, body = this.root.querySelector("#jobs tbody");
    const value = (j) => ({ id: j.id, status: j.status, arrived: j.arrived ?? Infinity, lead: j.lead ?? -1 })[key];
    const order = d.jobs.map((j, k) => k);
    const dir = this.sortKey === key ? -this.sortDir : (key === "lead" ? -1 : 1);
    this.sortKey = key; this.sortDir = dir;
    order.sort((a, b) => {
      const p = value(d.jobs[a]), q = value(d.jobs[b]);
      return (p < q ? -1 : p > q ? 1 : a - b) * dir;
    });
    for (const k of order) body.appendChild(this.jobRows[k]);
  }

  // The selected job's tasks, each a click away from its start.
  showJob(k) {
    const d = this.data, c = d.col, box = this.root.querySelector("#job-detail");
    this.jobRows.forEach((row, n) => row.classList.toggle("selected", n === k));
    box.replaceChildren();
    if (k < 0) { box.hidden = true; return; }
    box.hidden = false;
    const j = d.jobs[k];
    box.appendChild(element("h3", {}, `job ${j.id}: ${j.status}${j.reason ? ` (${j.reason})` : ""}`));
    box.appendChild(element("p", {}, `${j.pickup} → ${j.dropoff}; arrived ${formatTime(j.arrived)}, `
      + `ended ${formatTime(j.ended ?? NaN)}, lead time ${seconds(j.lead)}`));
    const list = element("ol", { class: "tasks" });
    for (const task of j.tasks) {
      const started = c["tasks.started"][task];
      const li = element("li", { "data-task": String(task) },
        `${d.taskLabels[c["tasks.label"][task]]} on ${d.robots[c["tasks.robot"][task]].id}: queued `
        + `${formatTime(c["tasks.queued"][task])}, started ${formatTime(started)}, ended `
        + `${formatTime(c["tasks.end"][task])} (${d.outcomes[c["tasks.outcome"][task]]})`);
      li.style.borderLeft = `6px solid ${taskColour(task)}`;
      li.addEventListener("click", () => this.app.seek(Number.isNaN(started) ? c["tasks.queued"][task] : started));
      list.appendChild(li);
    }
    box.appendChild(list);
  }

  buildIncidents() {
    this.incidentList = this.root.querySelector("#incidents");
    this.incidentCentre = -Infinity;
  }

  // The incidents around the cursor, the one at or before it marked.
  listIncidents(t, force) {
    const d = this.data, times = d.col["incidents.t"];
    const at = upperBound(times, t) - 1;
    if (!force && Math.abs(at - this.incidentCentre) < INCIDENT_WINDOW / 4) { this.markIncident(at); return; }
    this.incidentCentre = at;
    const from = Math.max(0, at - INCIDENT_WINDOW / 2), to = Math.min(times.length, from + INCIDENT_WINDOW);
    const list = this.incidentList;
    list.replaceChildren();
    if (!times.length) { list.appendChild(element("li", { class: "empty" }, "no incidents in this run")); return; }
    if (from > 0) list.appendChild(element("li", { class: "more" }, `${from} earlier (move the cursor back)`));
    for (let k = from; k < to; k++) {
      const kind = d.incidentKinds[d.col["incidents.kind"][k]];
      const li = element("li", { "data-incident": String(k) });
      const mark = element("span", { class: "mark" });
      mark.style.background = kind.colour;
      li.append(mark, element("span", { class: "when" }, formatTime(times[k])), ` ${d.incidentTexts[k]}`);
      li.addEventListener("click", () => this.app.jumpToIncident(k));
      list.appendChild(li);
    }
    if (to < times.length) list.appendChild(element("li", { class: "more" }, `${times.length - to} later`));
    this.markIncident(at);
  }

  markIncident(at) {
    this.incidentList.querySelectorAll("li.now").forEach((li) => li.classList.remove("now"));
    const li = this.incidentList.querySelector(`li[data-incident="${at}"]`);
    if (li) li.classList.add("now");
  }

  buildAbout() {
    const d = this.data, box = this.root.querySelector("#panel-about");
    const facts = [["scenario", d.scenario], ["seed", d.seed ?? "—"], ["written by", d.source],
      ["simulated", `${formatTime(d.end)}${d.complete ? "" : " so far (the run is incomplete or still running)"}`],
      ["robots", d.robots.length], ["stations", d.stations.length], ["legs", d.col["legs.t"].length],
      ["tasks", d.col["tasks.robot"].length], ["jobs", d.jobs.length]];
    const dl = element("dl");
    for (const [k, v] of facts) dl.append(element("dt", {}, k), element("dd", {}, String(v)));
    box.appendChild(dl);
  }
}
