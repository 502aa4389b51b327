// Time travel (sim_studio/timetravel.py): open a recording and scrub through it with one
// slider (the 3D view, the recorded frames, a plot, the expectation windows and verdicts),
// compare a second run (plotted, its verdicts beside, its models drawn as a translucent
// ghost in the 3D view), run the scenario (or its sweep) with its output streamed here and
// its report shown in the panel.
'use strict';
(function () {
  const S = window.studio;
  const tt = S.tt = {rec: [null, null], t: null, want: null, busy: false, at: null,
                     atReplies: 0, series: [null, null], runMessages: [], run: null,
                     opened: 0};
  const COL = ['#f66', '#6d6', '#69f', '#fc4', '#c8f', '#4dd'];
  const panel = S.panel('time travel', 'timetravel');
  panel.id = 'tt';
  panel.innerHTML = `
    <div class="tt-row"><input id="tt-path" data-testid="tt-path"
      placeholder="recording (.mcap, .bag) or its folder"><button id="tt-open"
      data-testid="tt-open">open</button></div>
    <div class="tt-row"><input id="tt-path-b" data-testid="tt-path-b"
      placeholder="a second recording to compare"><button id="tt-open-b"
      data-testid="tt-open-b">compare</button></div>
    <div id="tt-msg" data-testid="tt-msg"></div>
    <div id="tt-name" data-testid="tt-name"></div>
    <input id="tt-slider" data-testid="tt-slider" type="range" min="0" max="1" step="0.001"
      value="0" disabled>
    <canvas id="tt-timeline" data-testid="tt-timeline" width="340" height="54"></canvas>
    <label class="tt-row" id="tt-ghost-row" hidden title="the compared run's models where its recording has them at this time (those that are not where this run has them), translucent"><input type="checkbox" id="tt-ghost"
      data-testid="tt-ghost" checked> ghost of the compared run in the 3D view</label>
    <div class="tt-row">t = <b id="tt-time" data-testid="tt-time">-</b> s
      <button id="tt-first" data-testid="tt-first-failure">first failure</button>
      <button id="tt-live" data-testid="tt-live" title="the 3D view follows the world again">live</button></div>
    <div id="tt-frames" data-testid="tt-frames"></div>
    <select id="tt-field" data-testid="tt-field" title="the field plotted"></select>
    <canvas id="tt-plot" data-testid="tt-plot" width="340" height="110"></canvas>
    <table id="tt-verdicts" data-testid="tt-verdicts"></table>
    <h4>run</h4>
    <div class="tt-row"><input id="tt-file" data-testid="tt-file"
      placeholder="scenario file (empty: the YAML above)"><button id="tt-run"
      data-testid="tt-run" title="run_scenario --record --report">run + report</button></div>
    <div class="tt-row">sweep on <input id="tt-jobs" data-testid="tt-jobs" type="number"
      min="1" value="2" title="local workers"> workers or cluster <input id="tt-cluster"
      data-testid="tt-cluster" placeholder="host:port"><button id="tt-sweep"
      data-testid="tt-sweep">sweep</button></div>
    <pre id="tt-log" data-testid="tt-log"></pre>
    <div id="tt-runverdicts" data-testid="tt-run-verdicts"></div>
    <div id="tt-reportbar" hidden><a id="tt-reportlink" target="_blank">report in a tab</a></div>
    <iframe id="tt-report" data-testid="tt-report" hidden></iframe>`;
  const $ = (id) => document.getElementById(id);
  const slider = $('tt-slider');
  const msg = (text) => { $('tt-msg').textContent = text || ''; };

  // -- opening recordings ------------------------------------------------------------------
  function open(slot, path) {
    msg('opening ' + path + ' ...');
    return S.send({op: 'tt_open', path: path, slot: slot}).then((rep) => {
      if (!rep.ok) { msg(rep.error); return rep; }
      msg(rep.recording.warning || '');
      tt.rec[slot] = rep.recording;
      tt.series[slot] = null;
      tt.opened++;
      if (slot === 0) {
        const r = rep.recording;
        slider.min = r.t0; slider.max = r.t1; slider.disabled = false;
        $('tt-name').textContent = r.name + (r.status ? '  ' + r.status : '') +
          (r.poses ? '' : '  (no /gazebo/model_states recorded: the 3D view stays live)');
        fillFields();
        if (r.report) showReport(r.report);
        setT(tt.t === null || tt.t < r.t0 || tt.t > r.t1 ? r.t0 : tt.t);
      } else {
        fetchSeries();
        ghost.reset();
        if (tt.t !== null) ghost.ask(tt.t);
      }
      showVerdicts();
      drawTimeline();
      return rep;
    });
  }
  tt.open = open;
  $('tt-open').onclick = () => open(0, $('tt-path').value.trim());
  $('tt-open-b').onclick = () => open(1, $('tt-path-b').value.trim());

  // -- the time: one slider drives everything -----------------------------------------------
  function setT(t) {
    const r = tt.rec[0];
    if (!r) return;
    t = Math.min(r.t1, Math.max(r.t0, t));
    slider.value = t;
    tt.want = t;
    pump();
  }
  tt.setT = setT;
  function pump() {            // one tt_at at a time; the latest wanted time wins
    if (tt.busy || tt.want === null) return;
    const t = tt.want;
    tt.want = null;
    tt.busy = true;
    S.send({op: 'tt_at', slot: 0, t: t}).then((rep) => {
      tt.busy = false;
      if (rep.ok) show(rep); else msg(rep.error);
      pump();
    });
  }
  function show(rep) {
    tt.t = rep.t;
    tt.at = rep;
    tt.atReplies++;
    $('tt-time').textContent = rep.t.toFixed(3);
    if (Object.keys(rep.poses).length) {
      S.live = false;              // the recording's poses, not the world's
      S.poses = rep.poses;
      S.links = {};
    }
    const box = $('tt-frames');
    for (const topic of Object.keys(rep.frames).sort()) {
      let fig = box.querySelector('figure[data-topic="' + topic + '"]');
      if (!fig) {
        fig = document.createElement('figure');
        fig.dataset.topic = topic;
        fig.innerHTML = '<img data-testid="tt-frame"><figcaption></figcaption>';
        box.appendChild(fig);
      }
      const f = rep.frames[topic], img = fig.querySelector('img');
      if (img.getAttribute('src') !== f.url) img.src = f.url;
      fig.querySelector('figcaption').textContent = topic + ' at ' + f.t.toFixed(3) + ' s';
    }
    drawTimeline();
    drawPlot();
    ghost.ask(rep.t);
  }
  slider.addEventListener('input', () => setT(parseFloat(slider.value)));
  $('tt-live').onclick = () => { S.live = true; msg('live'); };
  $('tt-first').onclick = () => {
    const f = firstFailure();
    if (f) setT(f.t); else msg(tt.rec[0] ? 'no failure in this run' : 'open a recording');
  };
  function firstFailure() {
    const r = tt.rec[0];
    if (!r) return null;
    const bad = r.verdicts.filter((v) => v.status !== 'PASS' && v.t !== null)
      .sort((a, b) => a.t - b.t);
    return bad[0] || null;
  }
  tt.firstFailure = firstFailure;

  // -- the compared run in the 3D view: a ghost -----------------------------------------------
  // its models (the 3D view's own, cloned with translucent tinted materials: the same meshes)
  // where the compared recording's last /gazebo/model_states at or before the slider's time
  // (clamped to that recording) has them; only those not where this run has them then
  const GHOST_OPACITY = 0.35, GHOST_TINT = new THREE.Color(0x66ccff);
  const ghost = tt.ghost = {group: new THREE.Group(), models: {}, poses: {}, shown: [],
                            t: null, replies: 0, busy: false, want: null};
  ghost.group.name = 'tt-ghost';
  ghost.group.visible = false;
  S.scene3d.add(ghost.group);
  function ghostMaterial(m) {
    const g = m.clone();
    g.transparent = true;
    g.opacity = GHOST_OPACITY * (m.transparent ? m.opacity : 1);
    g.depthWrite = false;
    if (g.color) g.color = g.color.clone().lerp(GHOST_TINT, 0.5);
    return g;
  }
  function ghostOf(name) {
    if (!ghost.models[name] && S.models[name]) {
      const c = S.models[name].clone(true);
      c.traverse((o) => {
        if (o.isMesh) {
          o.material = Array.isArray(o.material) ? o.material.map(ghostMaterial) :
            ghostMaterial(o.material);
        }
      });
      c.name = name;
      ghost.group.add(c);
      ghost.models[name] = c;
    }
    return ghost.models[name];
  }
  const differs = (a, b) => !b || Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]) > 1e-3 ||
    Math.abs(a[3] * b[3] + a[4] * b[4] + a[5] * b[5] + a[6] * b[6]) < 1 - 1e-6;
  ghost.reset = () => {
    for (const name in ghost.models) ghost.group.remove(ghost.models[name]);
    ghost.models = {};
    ghost.poses = {};
    ghost.shown = [];
    ghost.t = null;
  };
  ghost.ask = (t) => {        // one tt_at of the compared run at a time; the latest wins
    const b = tt.rec[1];
    $('tt-ghost-row').hidden = !(b && b.poses);
    if (!b || !b.poses || !$('tt-ghost').checked) return;
    ghost.want = Math.min(b.t1, Math.max(b.t0, t));
    if (ghost.busy) return;
    ghost.busy = true;
    const tb = ghost.want;
    ghost.want = null;
    S.send({op: 'tt_at', slot: 1, t: tb}).then((rep) => {
      ghost.busy = false;
      if (rep.ok) showGhost(rep); else msg(rep.error);
      if (ghost.want !== null) ghost.ask(ghost.want);
    });
  };
  function showGhost(rep) {
    ghost.t = rep.t;
    ghost.poses = rep.poses;
    ghost.replies++;
    const here = (tt.at && tt.at.poses) || {};
    ghost.shown = [];
    for (const name of Object.keys(rep.poses).sort()) {
      const p = rep.poses[name], show = differs(p, here[name]) && !!ghostOf(name);
      if (show) {
        const g = ghost.models[name];
        g.position.set(p[0], p[1], p[2]);
        g.quaternion.set(p[3], p[4], p[5], p[6]);
        ghost.shown.push(name);
      }
      if (ghost.models[name]) ghost.models[name].visible = show;
    }
  }
  // where a ghost model's origin is (the browser test reads it from the scene graph)
  ghost.pose = (name) => {
    const g = ghost.models[name];
    if (!g || !g.visible) return null;
    g.updateMatrixWorld(true);
    const p = g.getWorldPosition(new THREE.Vector3()), q = g.getWorldQuaternion(new THREE.Quaternion());
    return [p.x, p.y, p.z, q.x, q.y, q.z, q.w];
  };
  $('tt-ghost').addEventListener('change', () => { if (tt.t !== null) ghost.ask(tt.t); });
  S.onFrame(() => {           // drawn while the view shows a recording, the toggle on
    ghost.group.visible = !S.live && !!tt.rec[1] && $('tt-ghost').checked && ghost.t !== null;
  });

  // -- the timeline: expectation windows, verdicts, events, the cursor ----------------------
  const tl = $('tt-timeline');
  function domain() {
    const r = tt.rec[0];
    if (r) return [r.t0, r.t1];
    const run = tt.run;
    let hi = 1;
    if (run) for (const x of runMarks(run)) hi = Math.max(hi, x.t);
    return [0, hi];
  }
  function runMarks(run) {
    const out = [];
    for (const ln of run.lines) {
      const m = /^\s*t=([\d.]+) s: (.*)$/.exec(ln);
      if (m) out.push({t: parseFloat(m[1]), event: m[2]});
    }
    for (const v of run.verdicts) if (v.t !== null) out.push(v);
    return out;
  }
  function drawTimeline() {
    const g = tl.getContext('2d'), w = tl.width, h = tl.height;
    const [t0, t1] = domain(), X = (t) => 4 + (t - t0) / Math.max(1e-9, t1 - t0) * (w - 8);
    g.fillStyle = '#15181c';
    g.fillRect(0, 0, w, h);
    const colour = (s) => s === 'PASS' ? '#6d6' : s === 'FAIL' ? '#f66' : '#fa4';
    const faint = (s) => s === 'PASS' ? 'rgba(102,221,102,0.3)' : s === 'FAIL' ?
      'rgba(255,102,102,0.35)' : 'rgba(255,170,68,0.35)';
    const rows = [];
    const r = tt.rec[0];
    if (r) {
      for (const e of r.events) rows.push({t: e.t, event: e.id});
      r.verdicts.forEach((v, i) => rows.push(Object.assign({row: i, slot: 0}, v)));
      if (tt.rec[1]) {
        tt.rec[1].verdicts.forEach((v, i) => rows.push(Object.assign({row: i, slot: 1}, v)));
      }
    } else if (tt.run) {
      runMarks(tt.run).forEach((x, i) => rows.push(Object.assign({row: i, slot: 0}, x)));
    }
    const nv = Math.max(1, rows.filter((x) => !x.event).length);
    const rowH = Math.max(3, Math.min(8, (h - 12) / nv));
    let k = 0;
    for (const x of rows) {
      if (x.event !== undefined) {
        g.fillStyle = '#9ab';
        g.fillRect(X(x.t) - 0.5, 0, 1, 8);
        continue;
      }
      const y = 10 + (k++) * rowH;
      if (x.window) {
        g.fillStyle = faint(x.status);
        g.fillRect(X(x.window[0]), y, Math.max(1, X(x.window[1]) - X(x.window[0])), rowH - 1);
      }
      if (x.t !== null && x.t !== undefined) {
        g.fillStyle = colour(x.status);
        g.beginPath();
        g.arc(X(x.t), y + rowH / 2, x.slot ? 2 : 3, 0, 2 * Math.PI);
        g.fill();
      }
    }
    if (tt.t !== null && r) {
      g.fillStyle = '#fff';
      g.fillRect(X(tt.t) - 1, 0, 2, h);
    }
  }
  tl.addEventListener('click', (e) => {
    const rect = tl.getBoundingClientRect(), [t0, t1] = domain();
    setT(t0 + (e.clientX - rect.left - 4) / (rect.width - 8) * (t1 - t0));
  });

  // -- the plot: a recorded field, the second run overlaid, the windows shaded ----------------
  function fillFields() {
    const sel = $('tt-field'), r = tt.rec[0];
    sel.innerHTML = '';
    const add = (value, text) => {
      const o = document.createElement('option');
      o.value = value; o.textContent = text;
      sel.appendChild(o);
    };
    const seen = new Set();
    for (const v of r.verdicts) {
      const info = v.topic && r.topics[v.topic];
      if (v.field && info && info.fields.some((f) => f === v.field || f.startsWith(v.field))) {
        add(v.topic + ' ' + v.field, v.name + ': ' + v.topic + ' ' + v.field);
        seen.add(v.topic + ' ' + v.field);
      }
    }
    for (const topic of Object.keys(r.topics)) {
      for (const f of r.topics[topic].fields) {
        if (!seen.has(topic + ' ' + f)) add(topic + ' ' + f, topic + ' ' + f);
      }
    }
    const bad = firstFailure();
    if (bad && seen.has(bad.topic + ' ' + bad.field)) sel.value = bad.topic + ' ' + bad.field;
    fetchSeries();
  }
  $('tt-field').addEventListener('change', () => { tt.series = [null, null]; fetchSeries(); });
  function fetchSeries() {
    const v = $('tt-field').value;
    if (!v) return;
    const i = v.indexOf(' '), topic = v.slice(0, i), field = v.slice(i + 1);
    [0, 1].forEach((slot) => {
      const r = tt.rec[slot];
      if (!r || !r.topics[topic]) { tt.series[slot] = null; drawPlot(); return; }
      S.send({op: 'tt_series', slot: slot, topic: topic, field: field, points: 600})
        .then((rep) => {
          if (!rep.ok) { msg(rep.error); return; }
          tt.series[slot] = rep;
          drawPlot();
        });
    });
  }
  function drawPlot() {
    const c = $('tt-plot'), g = c.getContext('2d'), w = c.width, h = c.height;
    g.fillStyle = '#15181c';
    g.fillRect(0, 0, w, h);
    const r = tt.rec[0], A = tt.series[0];
    if (!r || !A) return;
    const [t0, t1] = [r.t0, r.t1], X = (t) => 4 + (t - t0) / Math.max(1e-9, t1 - t0) * (w - 8);
    let lo = Infinity, hi = -Infinity;
    for (const s of [A, tt.series[1]]) {
      if (!s) continue;
      for (const [, pts] of s.series) for (const p of pts) { lo = Math.min(lo, p[1]); hi = Math.max(hi, p[1]); }
    }
    if (!isFinite(lo)) return;
    const span = hi - lo || 1, Y = (v) => h - 10 - (v - lo) / span * (h - 20);
    for (const v of r.verdicts) {             // the windows of expectations on this field
      if (v.topic !== A.topic || !v.window || !(v.field || '').startsWith(A.field.split('[')[0])) continue;
      g.fillStyle = v.status === 'PASS' ? 'rgba(102,221,102,0.2)' : 'rgba(255,102,102,0.25)';
      g.fillRect(X(v.window[0]), 0, Math.max(1, X(v.window[1]) - X(v.window[0])), h);
    }
    [A, tt.series[1]].forEach((s, slot) => {
      if (!s) return;
      g.setLineDash(slot ? [4, 3] : []);
      s.series.forEach(([, pts], k) => {
        g.strokeStyle = COL[(k + 3 * slot) % COL.length];
        g.beginPath();
        pts.forEach((p, j) => { if (j) g.lineTo(X(p[0]), Y(p[1])); else g.moveTo(X(p[0]), Y(p[1])); });
        g.stroke();
      });
    });
    g.setLineDash([]);
    g.fillStyle = '#aaa';
    g.font = '10px monospace';
    g.fillText(hi.toPrecision(4), 2, 9);
    g.fillText(lo.toPrecision(4), 2, h - 1);
    if (tt.rec[1]) g.fillText('--- ' + tt.rec[1].name, w - 150, 9);
    if (tt.t !== null) { g.fillStyle = '#fff'; g.fillRect(X(tt.t) - 0.5, 0, 1, h); }
  }

  // -- verdicts side by side ----------------------------------------------------------------
  function showVerdicts() {
    const tab = $('tt-verdicts'), [a, b] = tt.rec;
    tab.innerHTML = '';
    if (!a) return;
    const names = a.verdicts.map((v) => v.name);
    if (b) for (const v of b.verdicts) if (!names.includes(v.name)) names.push(v.name);
    const head = document.createElement('tr');
    head.innerHTML = '<th></th><th></th>' + (b ? '<th></th>' : '');
    head.children[1].textContent = a.name;
    if (b) head.children[2].textContent = b.name;
    tab.appendChild(head);
    const cell = (v) => {
      const td = document.createElement('td');
      if (!v) { td.textContent = '-'; return td; }
      td.className = v.status;
      td.textContent = v.status + (v.t !== null ? ' ' + v.t.toFixed(3) + ' s' : '');
      td.title = 'expected ' + v.expected + '; actual ' + v.actual;
      return td;
    };
    for (const n of names) {
      const tr = document.createElement('tr'), va = a.verdicts.find((v) => v.name === n);
      tr.dataset.name = n;
      const th = document.createElement('td');
      th.textContent = n;
      tr.appendChild(th);
      tr.appendChild(cell(va));
      if (b) tr.appendChild(cell(b.verdicts.find((v) => v.name === n)));
      tr.onclick = () => { if (va && va.t !== null) setT(va.t); };
      tab.appendChild(tr);
    }
    if (!a.verdicts.length) {
      const tr = document.createElement('tr');
      tr.innerHTML = '<td colspan="3">no report.json beside this recording: no verdicts</td>';
      tab.appendChild(tr);
    }
  }

  // -- running: the output streamed, the verdicts as they come, the report ----------------------
  function showReport(url) {
    $('tt-report').hidden = false;
    $('tt-reportbar').hidden = false;
    $('tt-reportlink').href = url;
    if ($('tt-report').getAttribute('src') !== url) $('tt-report').src = url;
  }
  function startRun(sweep) {
    const file = $('tt-file').value.trim(), cmd = {op: 'tt_run', sweep: sweep};
    if (file) cmd.file = file; else cmd.yaml = document.getElementById('yaml').value;
    if (sweep) {
      const c = $('tt-cluster').value.trim();
      if (c) cmd.cluster = c; else cmd.jobs = Math.max(1, parseInt($('tt-jobs').value, 10) || 1);
    }
    $('tt-log').textContent = 'starting...';
    return S.send(cmd).then((rep) => { if (!rep.ok) { msg(rep.error); $('tt-log').textContent = ''; } return rep; });
  }
  $('tt-run').onclick = () => startRun(false);
  $('tt-sweep').onclick = () => startRun(true);
  S.on('tt_run', (m) => {
    tt.run = m;
    tt.runMessages.push({state: m.state, lines: m.lines.length, verdicts: m.verdicts.length});
    $('tt-run').disabled = $('tt-sweep').disabled = m.state === 'running';
    $('tt-log').textContent = m.lines.slice(-14).join('\n');
    const box = $('tt-runverdicts');
    box.textContent = '';
    for (const v of m.verdicts) box.appendChild(S.line(v.status, v.line));
    if (m.state === 'done') {
      box.appendChild(S.line(m.status, 'run ' + m.run + ': ' + m.status +
        (m.summary ? ' (' + m.summary.passed + '/' + m.summary.total + ' runs passed)' : '')));
      if (m.report) showReport(m.report);
      if (m.recording && tt.lastOpenedRun !== m.run) {
        tt.lastOpenedRun = m.run;
        $('tt-path').value = m.recording;
        open(0, m.recording);
      }
    }
    if (!tt.rec[0]) drawTimeline();
  });

  // ?recording=PATH (&compare=PATH): a report's or a script's link opens it here
  // (the hello may have come before this script ran: studio.name is set by it)
  let asked = false;
  const fromLink = () => {
    if (asked) return;
    asked = true;
    const q = new URLSearchParams(location.search);
    if (q.get('recording')) {
      $('tt-path').value = q.get('recording');
      open(0, q.get('recording')).then(() => {
        if (q.get('compare')) { $('tt-path-b').value = q.get('compare'); open(1, q.get('compare')); }
      });
    }
  };
  S.on('hello', fromLink);
  if (S.name) fromLink();
  drawTimeline();
  drawPlot();
})();
