// The maintenance page: polls /state.json every second and swaps in each new picture. Read-only.
"use strict";
const $ = (id) => document.getElementById(id);
const fmt = (v) => (v === null || v === undefined ? "-" : String(v));
let shown = { left: 0, right: 0 };
let failures = 0;

function cell(tr, value, cls) {
  const td = document.createElement("td");
  td.textContent = fmt(value);
  if (cls) td.className = cls;
  tr.appendChild(td);
  return td;
}

function fill(id, rows) {  // rows: arrays of [value, class] or values
  const body = $(id).tBodies[0];
  body.replaceChildren();
  for (const row of rows) {
    const tr = document.createElement("tr");
    for (const v of row) Array.isArray(v) ? cell(tr, v[0], v[1]) : cell(tr, v);
    body.appendChild(tr);
  }
}

function counters(obj) {
  return Object.entries(obj || {}).map(([k, v]) => `${k} ${v}`).join(", ");
}

function render(s) {
  const h = s.health;
  $("state").textContent = h.state;
  $("state").className = "state " + h.state;
  $("status-line").textContent = h.status_line;
  fill("tracks", s.tracks.map((t) => [t.number, t.id, t.status, t.range_m, t.bearing_deg, t.sog_kn,
    t.cog_deg, t.sigma_m, t.age_s, [t.name || (t.mmsi ? t.mmsi : ""), "left"]]));
  const c = s.counters;
  fill("counters", [["fps", c.fps], ["pairs processed", c.processed], ["pairs dropped", c.dropped],
    ["pairs bad / failed", `${c.bad_input} / ${c.failed}`], ["gaps", c.gaps], ["detections", c.detections],
    ["fixes", c.fixes], ["capture errors", c.capture_errors], ["reloads", c.reloads]]);
  const leds = Object.entries(h.leds).map(([k, v]) => `${k} ${v}`).join(", ") || "none";
  const d = h.disk;
  fill("health", [["state", [h.state + (h.reason ? ": " + h.reason : ""), "left"]],
    ["fault code", h.fault_code], ["latency s", h.latency_s], ["uptime s", h.uptime_s],
    ["LEDs", [leds, "left"]],
    ["clock", [h.clock.synchronised ? "synchronised" : (h.clock.required ? "NOT synchronised" : "not synchronised (not required)"), h.clock.synchronised ? "left" : "left stale"]],
    ["disk", [d.error ? d.error : `${d.free_mb} MB free at ${d.path} (needs ${d.min_free_mb})`, d.ok === false || d.error ? "left fault" : "left"]],
    ["flags", [h.flags.join(" "), "left"]]]);
  fill("stages", h.stages.map((st) => [st.name, [st.fresh ? "yes" : "NO", st.fresh ? "" : "stale"], st.age_s,
    [st.fault || "", "left fault"]]));
  fill("outputs", s.outputs.map((o) => [o.kind, [o.where, "left"], [o.fault || "", "left fault"],
    [counters(o.counters), "left"]]));
  fill("ais", s.ais ? [["fault", [s.ais.fault || "none", s.ais.fault ? "left fault" : "left"]],
    ["tracks with AIS", s.ais.associated], ["dark tracks", s.ais.dark],
    ...Object.entries(s.ais.counters).map(([k, v]) => [k, v])] : [["AIS", ["off (no ais: block)", "left"]]]);
  fill("alerts", s.alerts.map((a) => [a.alert + " (" + a.id + ")", a.state + " " + a.priority,
    a.tracks.join(" "), a.cpa_m, a.tcpa_s, a.age_s]));
  for (const side of ["left", "right"]) {
    const seq = s.pictures[side];
    if (seq && seq !== shown[side]) {
      shown[side] = seq;
      $(side).src = `${side}.jpg?n=${seq}`;
      $(side + "-seq").textContent = "#" + seq;
    }
  }
  $("updated").textContent = "updated " + s.time_utc;
}

for (const side of ["left", "right"]) {
  $(side).addEventListener("load", () => { $(side).dataset.loads = String(Number($(side).dataset.loads) + 1); });
}

async function poll() {
  try {
    const r = await fetch("state.json", { cache: "no-store" });
    if (!r.ok) throw new Error(r.status);
    render(await r.json());
    failures = 0;
  } catch (e) {
    failures += 1;
    $("status-line").textContent = "no answer from the appliance (" + e + ")";
  }
  setTimeout(poll, failures ? 2000 : 500);
}
poll();
