// Plots picked by field (issue 47 part 3) and assert mode on plot points and the LED (part 4).
// A `+` button (data-testid="plot-pick") before each numeric device value puts that field of
// that topic into the panel `plots` (data-testid="plots"): one canvas (`field-plot`) drawing
// every picked field over the last 30 s of sim time (each scaled to its own range, its
// range in the legend), a legend entry per field (`plot-legend`) with a remove button
// (`plot-remove`). In assert mode a click on the plot opens the core's assert form with the
// field and value of the nearest point; a click on the LED (moves.js's `out-led`) adds one
// expectation per colour component (`near`, tol 0.002: ColorRGBA is float32 and the YAML
// writes 6 decimals, so `equals` with tol 0 could never hold for 0.2). Page only: the
// core's `expect` op and the device stream carry all of it.
'use strict';
(function () {
  const S = window.studio;
  const $ = (id) => document.getElementById(id);
  const COLORS = ['#f66', '#6d6', '#69f', '#fc4', '#d6f', '#4dd', '#fa8', '#aaa'];
  const SPAN = 30;                          // s of sim time shown
  const P = S.plots = {fields: [], draws: 0, points: []};   // points: drawn [x, y, field, t, v]

  const box = S.panel('plots (pick a device value\'s +)', 'plots');
  box.className = 'plots';
  const canvas = document.createElement('canvas');
  canvas.width = 320;
  canvas.height = 140;
  canvas.dataset.testid = 'field-plot';
  canvas.title = 'picked fields over the last 30 s of sim time; in assert mode a click ' +
    'on a point expects its value';
  const legend = document.createElement('div');
  legend.className = 'legend';
  legend.dataset.testid = 'plot-legend';
  box.append(canvas, legend);

  const key = (topic, field) => topic + ' ' + field;
  function find(topic, field) { return P.fields.find((f) => f.topic === topic && f.field === field); }

  function pick(topic, field) {
    if (find(topic, field)) return;
    const used = new Set(P.fields.map((f) => f.color));
    const color = COLORS.find((c) => !used.has(c)) || COLORS[P.fields.length % COLORS.length];
    const f = {topic: topic, field: field, color: color, hist: []};
    P.fields.push(f);
    const row = document.createElement('div');
    row.className = 'entry';
    row.dataset.topic = topic;
    row.dataset.field = field;
    row.innerHTML = '<span class="swatch"></span> <span class="name"></span> ' +
      '<span class="range"></span> <button type="button" data-testid="plot-remove" ' +
      'title="remove from the plot">x</button>';
    row.querySelector('.swatch').style.background = color;
    row.querySelector('.name').textContent = key(topic, field);
    row.querySelector('button').onclick = () => unpick(topic, field);
    f.row = row;
    legend.appendChild(row);
    const v = S.device[topic];
    if (v) take(f, v, S.simTime);
    draw();
  }
  function unpick(topic, field) {
    const f = find(topic, field);
    if (!f) return;
    P.fields.splice(P.fields.indexOf(f), 1);
    f.row.remove();
    draw();
  }
  P.pick = pick;
  P.unpick = unpick;

  // the latest value of a picked field from one device message's topic
  function take(f, v, t0) {
    const t = v.stamp !== null && v.stamp !== undefined ? v.stamp : t0;
    const pair = v.fields.find((p) => p[0] === f.field);
    if (!pair || typeof pair[1] !== 'number' || !isFinite(pair[1]) || typeof t !== 'number') return;
    const h = f.hist;
    if (h.length && t < h[h.length - 1].t) h.length = 0;         // a reset: time went back
    if (!h.length || t > h[h.length - 1].t) h.push({t: t, v: pair[1]});
  }

  // `+` beside each numeric device value
  S.on('device', (m) => {
    for (const cell of document.querySelectorAll('#device td.v')) {
      const row = cell.parentNode;
      if (row.querySelector('button.pick')) continue;
      const v = m.topics[cell.dataset.topic];
      const pair = v && v.fields.find((p) => p[0] === cell.dataset.field);
      if (!pair || typeof pair[1] !== 'number') continue;
      const td = document.createElement('td');
      const b = document.createElement('button');
      b.type = 'button';
      b.className = 'pick';
      b.textContent = '+';
      b.title = 'plot this field';
      b.dataset.testid = 'plot-pick';
      b.dataset.topic = cell.dataset.topic;
      b.dataset.field = cell.dataset.field;
      b.onclick = (e) => { e.stopPropagation(); pick(b.dataset.topic, b.dataset.field); };
      td.appendChild(b);
      row.insertBefore(td, cell);      // studio.js writes the value into row.lastChild
    }
    for (const f of P.fields) {
      if (m.topics[f.topic]) take(f, m.topics[f.topic], m.t);
    }
    draw();
  });

  function draw() {
    const g = canvas.getContext('2d'), w = canvas.width, ht = canvas.height;
    g.fillStyle = '#15181c';
    g.fillRect(0, 0, w, ht);
    P.points = [];
    let t1 = -Infinity;
    for (const f of P.fields) if (f.hist.length) t1 = Math.max(t1, f.hist[f.hist.length - 1].t);
    if (!isFinite(t1)) return;
    const t0 = t1 - SPAN;
    g.strokeStyle = '#333';
    g.beginPath();
    for (let s = Math.ceil(t0 / 5) * 5; s <= t1; s += 5) {      // a tick every 5 s
      const x = (s - t0) / SPAN * (w - 2) + 1;
      g.moveTo(x, 0);
      g.lineTo(x, ht);
    }
    g.stroke();
    for (const f of P.fields) {
      while (f.hist.length && f.hist[0].t < t0) f.hist.shift();
      const h = f.hist;
      let lo = Infinity, hi = -Infinity;
      for (const p of h) { lo = Math.min(lo, p.v); hi = Math.max(hi, p.v); }
      f.row.querySelector('.range').textContent = h.length ?
        '[' + fmt(lo) + ', ' + fmt(hi) + ']' : '(no value yet)';
      if (!h.length) continue;
      const span = hi - lo;
      g.strokeStyle = g.fillStyle = f.color;
      g.lineWidth = 2;
      g.beginPath();
      h.forEach((p, i) => {
        const x = (p.t - t0) / SPAN * (w - 2) + 1;
        const y = span ? ht - 4 - (p.v - lo) / span * (ht - 8) : ht / 2;
        P.points.push([x, y, f, p.t, p.v]);
        if (i) g.lineTo(x, y); else g.moveTo(x, y);
      });
      if (h.length === 1) g.fillRect(P.points[P.points.length - 1][0] - 2, P.points[P.points.length - 1][1] - 2, 4, 4);
      g.stroke();
    }
    P.draws++;
  }
  function fmt(v) {
    if (v !== 0 && (Math.abs(v) >= 1e6 || Math.abs(v) < 1e-3)) return v.toExponential(3);
    return String(parseFloat(v.toPrecision(5)));
  }

  // -- assert mode: a point of the plot, the LED colour -----------------------------------
  canvas.addEventListener('click', (e) => {
    if (!S.asserting || !P.points.length) return;
    const r = canvas.getBoundingClientRect();
    const x = (e.clientX - r.left) * canvas.width / r.width;
    const y = (e.clientY - r.top) * canvas.height / r.height;
    let best = null, bd = Infinity;
    for (const p of P.points) {
      const d = (p[0] - x) * (p[0] - x) + (p[1] - y) * (p[1] - y);
      if (d < bd) { bd = d; best = p; }
    }
    const f = best[2], v = best[4];
    P.clicked = {topic: f.topic, field: f.field, t: best[3], value: v};
    const form = $('assertform');
    form.dataset.topic = f.topic;
    form.dataset.field = f.field;
    $('a-what').textContent = f.topic + ' ' + f.field + ' (at ' + best[3].toFixed(2) + ' s)';
    form.elements.a.value = v;
    form.elements.b.value = parseFloat((Math.abs(v) * 0.1 || 0.1).toPrecision(3));
    form.hidden = false;
  });

  document.addEventListener('click', (e) => {
    const led = e.target.closest && e.target.closest('[data-testid="out-led"]');
    if (!S.asserting || !led) return;
    const topic = '/' + S.selected + '/led/state', v = S.device[topic];
    if (!v) { S.showError({ok: false, error: 'no LED state (' + topic + ') yet'}); return; }
    const c = Object.fromEntries(v.fields);
    const sends = ['r', 'g', 'b'].map((k) => S.send({
      op: 'expect', topic: topic, field: k, mode: 'eventually', check: 'near',
      target: c[k], tol: 0.002, name: 'led_' + k}));
    Promise.all(sends).then((reps) => {
      for (const rep of reps) S.showError(rep);
      const last = reps.filter((rep) => rep.ok).pop();
      if (last) $('yaml').value = last.yaml;
    });
  });
})();
