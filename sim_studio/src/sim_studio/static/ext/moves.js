// The studio's moves and world overlays (sim_studio/moves.py, overlay.py): presets, a walk
// clicked on a top view, icons for lights and radios, the WiFi map over the floor, and the
// device panel's switches, environment, faults and outputs.
'use strict';
(function () {
  const studio = window.studio;
  const THREE = window.THREE;
  const M = studio.moves = {waypoints: [], icons: {}, overlay: null, bounds: null,
                            topFrames: 0, info: null};
  const el = (tag, attrs, text) => {
    const e = document.createElement(tag);
    for (const k in attrs || {}) {
      if (k === 'testid') e.dataset.testid = attrs[k]; else e.setAttribute(k, attrs[k]);
    }
    if (text !== undefined) e.textContent = text;
    return e;
  };
  const say = (rep) => { studio.showError(rep); return rep; };
  // read-only ops over POST /api/cmd: their answers do not wait behind the stream's
  // messages on the WebSocket (a busy page reads those late)
  function ask(cmd) {
    cmd.v = 1;
    return fetch('/api/cmd', {method: 'POST', body: JSON.stringify(cmd)})
      .then((r) => r.json())
      .catch((e) => ({ok: false, error: String(e)}));
  }
  M.ask = ask;
  function phone() {
    if (studio.displays[studio.selected]) return studio.selected;
    return Object.keys(studio.displays)[0] || 'mobile_device';
  }

  // -- presets --------------------------------------------------------------------------------
  const moves = studio.panel('move the phone', 'moves-panel');
  moves.className = 'moves';
  const PRESETS = {flat_on_desk: 'flat on the desk', face_down: 'face down',
                   held_portrait: 'held in portrait', in_pocket: 'in a pocket'};
  const presets = el('div', {class: 'row'});
  for (const name in PRESETS) {
    const b = el('button', {testid: 'preset-' + name, title: 'preset ' + name}, PRESETS[name]);
    b.onclick = () => studio.send({op: 'preset', model: studio.selected, name: name}).then(say);
    presets.append(b);
  }
  moves.append(presets);

  // -- the top view: click waypoints, set a speed, walk -----------------------------------------
  const top = el('canvas', {testid: 'top-view', width: 320, height: 300,
                            title: 'top view (north up): a click adds a waypoint'});
  const speed = el('input', {type: 'number', step: '0.1', min: '0.1', value: '1.2',
                             testid: 'walk-speed', title: 'walking speed, m/s'});
  const walkB = el('button', {testid: 'walk'}, 'walk');
  const clearB = el('button', {testid: 'walk-clear'}, 'clear');
  const wpText = el('span', {testid: 'waypoints'}, '');
  // the height (m, world z) of the waypoints clicked next; empty: the model's height now
  const height = el('input', {type: 'number', step: '0.05', testid: 'walk-height',
                              style: 'width:5em', placeholder: 'height m',
                              title: "height of the clicked waypoints, m (empty: the model's now)"});
  const row = el('div', {class: 'row'});
  row.append('speed ', speed, ' m/s height ', height, ' m ', walkB, clearB, ' ', wpText);
  moves.append(el('div', {class: 'hint'}, 'top view: click waypoints, then walk'), top, row);
  const topCam = new THREE.OrthographicCamera(-1, 1, 1, -1, 0.1, 200);
  topCam.up.set(0, 1, 0);
  function setBounds(b) {
    // keep the canvas's aspect: widen the shorter side
    const w = b[1] - b[0], h = b[3] - b[2], asp = top.width / top.height;
    const cx = (b[0] + b[1]) / 2, cy = (b[2] + b[3]) / 2;
    const hw = Math.max(w, h * asp) / 2, hh = hw / asp;
    M.bounds = [cx - hw, cx + hw, cy - hh, cy + hh];
    topCam.left = -hw; topCam.right = hw; topCam.top = hh; topCam.bottom = -hh;
    topCam.position.set(cx, cy, 60);
    topCam.lookAt(cx, cy, 0);
    topCam.updateProjectionMatrix();
  }
  // the page point of a world point (x, y) on the top view (the browser test clicks there)
  M.topPoint = (x, y) => {
    const r = top.getBoundingClientRect(), b = M.bounds;
    return {x: r.left + (x - b[0]) / (b[1] - b[0]) * r.width,
            y: r.top + (b[3] - y) / (b[3] - b[2]) * r.height};
  };
  function topWorld(e) {
    const r = top.getBoundingClientRect(), b = M.bounds;
    return [b[0] + (e.clientX - r.left) / r.width * (b[1] - b[0]),
            b[3] - (e.clientY - r.top) / r.height * (b[3] - b[2])];
  }
  function drawTop() {
    if (!M.bounds) return;
    const g = top.getContext('2d');
    // drawn by the page's renderer into a corner of the 3D view's canvas (a second WebGL
    // context would compile every shader again), copied from there before the view's frame
    // is drawn over it
    const r = studio.renderer, c = r.domElement, k = r.getPixelRatio();
    const w = top.width / k, h = top.height / k, size = r.getSize(new THREE.Vector2());
    const handle = studio.handle.visible;
    studio.handle.visible = false;
    r.setScissorTest(true);
    r.setScissor(0, 0, w, h);
    r.setViewport(0, 0, w, h);
    r.render(studio.scene3d, topCam);
    g.drawImage(c, 0, c.height - top.height, top.width, top.height, 0, 0, top.width, top.height);
    r.setScissorTest(false);
    r.setViewport(0, 0, size.x, size.y);
    studio.handle.visible = handle;
    const px = (p) => [(p[0] - M.bounds[0]) / (M.bounds[1] - M.bounds[0]) * top.width,
                       (M.bounds[3] - p[1]) / (M.bounds[3] - M.bounds[2]) * top.height];
    const obj = studio.models[studio.selected];
    if (obj) height.placeholder = obj.position.z.toFixed(2) + ' (now)';
    const pts = [];
    if (obj) pts.push([obj.position.x, obj.position.y]);
    for (const w of M.waypoints) pts.push(w);
    g.strokeStyle = '#ff0';
    g.lineWidth = 2;
    g.beginPath();
    pts.forEach((p, i) => { const q = px(p); if (i) g.lineTo(q[0], q[1]); else g.moveTo(q[0], q[1]); });
    g.stroke();
    g.fillStyle = '#ff0';
    for (const w of M.waypoints) {
      const q = px(w);
      g.fillRect(q[0] - 3, q[1] - 3, 6, 6);
    }
    if (obj) {
      const q = px([obj.position.x, obj.position.y]);
      g.fillStyle = '#f0f';
      g.beginPath();
      g.arc(q[0], q[1], 4, 0, 2 * Math.PI);
      g.fill();
    }
    M.topFrames++;
  }
  top.addEventListener('click', (e) => {
    if (!M.bounds) return;
    const obj = studio.models[studio.selected];
    const xy = topWorld(e);
    const z = parseFloat(height.value);
    M.waypoints.push([xy[0], xy[1], Number.isFinite(z) ? z : (obj ? obj.position.z : 1.0)]);
    wpText.textContent = M.waypoints.length + ' waypoint(s)';
    drawTop();
  });
  clearB.onclick = () => { M.waypoints = []; wpText.textContent = ''; drawTop(); };
  walkB.onclick = () => {
    studio.send({op: 'walk', model: studio.selected, waypoints: M.waypoints,
                 speed: parseFloat(speed.value)}).then((rep) => {
      say(rep);
      M.lastWalk = rep;
      if (rep.ok) { M.waypoints = []; wpText.textContent = 'walking until ' + rep.end.toFixed(2) + ' s'; }
    });
  };
  // redrawn once a second while it is on the screen (a second WebGL view costs the page)
  let topAt = 0, topSeen = false;
  new IntersectionObserver((es) => { topSeen = es[es.length - 1].isIntersecting; })
    .observe(top);
  studio.onFrame((now) => {
    if (topSeen && now - topAt > 1000) { topAt = now; drawTop(); }
  });

  // -- icons for lights and radios, and the WiFi map over the floor ---------------------------
  const COLORS = {wifi: '#0096ff', bluetooth: '#8040ff', nfc: '#ff7800', light: '#ffd200',
                  cell: '#30c030'};
  const GLYPH = {wifi: 'W', bluetooth: 'B', nfc: 'N', light: 'L', cell: 'C'};
  M.colors = COLORS;
  function iconTexture(kind) {
    const c = document.createElement('canvas');
    c.width = c.height = 64;
    const g = c.getContext('2d');
    g.fillStyle = COLORS[kind];
    g.beginPath();
    g.arc(32, 32, 30, 0, 2 * Math.PI);
    g.fill();
    g.fillStyle = '#fff';
    g.font = 'bold 22px sans-serif';
    g.textAlign = 'center';
    g.textBaseline = 'middle';
    g.fillText(GLYPH[kind], 32, 33);
    return new THREE.CanvasTexture(c);
  }
  const textures = {};
  const layer = el('div', {class: 'row'});
  const iconsBox = el('input', {type: 'checkbox', testid: 'icons', checked: ''});
  const overlayBox = el('input', {type: 'checkbox', testid: 'wifi-overlay'});
  const apSel = el('select', {testid: 'wifi-ap', title: 'the access point of the map'});
  apSel.append(el('option', {value: ''}, 'strongest AP'));
  const mapText = el('span', {testid: 'wifi-map-status'}, '');
  const lbl = (box, text) => { const l = el('label'); l.append(box, ' ' + text); return l; };
  layer.append(lbl(iconsBox, 'icons'), ' ', lbl(overlayBox, 'WiFi map'), ' ', apSel, ' ', mapText);
  const legend = el('div', {class: 'hint', testid: 'icon-legend'});
  for (const k in COLORS) {
    const s = el('span', {class: 'swatch'});
    s.style.background = COLORS[k];
    legend.append(s, ' ' + k + ' ');
  }
  moves.append(layer, legend);

  function addIcons(info) {
    M.info = info;
    for (const ic of info.icons) {
      const key = ic.kind + ':' + ic.id;
      if (M.icons[key]) continue;
      textures[ic.kind] = textures[ic.kind] || iconTexture(ic.kind);
      const sp = new THREE.Sprite(new THREE.SpriteMaterial({
        map: textures[ic.kind], depthTest: false, depthWrite: false, sizeAttenuation: false}));
      sp.scale.set(0.05, 0.05, 1);
      sp.renderOrder = 10;
      sp.name = 'icon:' + key;
      sp.userData = ic;
      const parent = ic.model && studio.models[ic.model];
      if (parent) sp.position.set(ic.offset[0], ic.offset[1], ic.offset[2]);
      else sp.position.set(ic.position[0], ic.position[1], ic.position[2]);
      (parent || studio.scene3d).add(sp);
      sp.visible = iconsBox.checked;
      M.icons[key] = sp;
      if (ic.kind === 'wifi' && !apSel.querySelector('option[value="' + ic.id + '"]')) {
        apSel.append(el('option', {value: ic.id}, ic.id + ' (' + ic.name + ', ch ' + ic.channel + ')'));
      }
    }
    if (info.bounds && !M.bounds) setBounds(info.bounds);
  }
  M.addIcons = addIcons;        // ext/spawned.js: the icons of models spawned since
  // where an icon is on the page (the browser test looks at the viewport's pixels there)
  M.iconPoint = (kind, id) => {
    const sp = M.icons[kind + ':' + id];
    if (!sp) return null;
    const p = sp.getWorldPosition(new THREE.Vector3()).project(studio.camera);
    const r = studio.renderer.domElement.getBoundingClientRect();
    return {x: r.left + (p.x + 1) / 2 * r.width, y: r.top + (1 - p.y) / 2 * r.height,
            visible: p.z < 1 && Math.abs(p.x) < 1 && Math.abs(p.y) < 1};
  };
  iconsBox.onchange = () => { for (const k in M.icons) M.icons[k].visible = iconsBox.checked; };

  function showOverlay(on) {
    if (M.overlay) M.overlay.visible = false;
    if (!on) { mapText.textContent = ''; return; }
    mapText.textContent = 'computing...';
    ask({op: 'wifi_map', bssid: apSel.value || undefined}).then((rep) => {
      if (!rep.ok) { say(rep); mapText.textContent = rep.error; return; }
      if (!overlayBox.checked) return;
      const b = rep.bounds;
      new THREE.TextureLoader().load(rep.image, (tex) => {
        tex.magFilter = THREE.NearestFilter;
        if (M.overlay) { studio.scene3d.remove(M.overlay); M.overlay.material.map.dispose(); }
        const mesh = new THREE.Mesh(new THREE.PlaneBufferGeometry(b[1] - b[0], b[3] - b[2]),
          new THREE.MeshBasicMaterial({map: tex, transparent: true, depthWrite: false,
                                       side: THREE.DoubleSide}));
        mesh.position.set((b[0] + b[1]) / 2, (b[2] + b[3]) / 2, 0.02);
        mesh.renderOrder = 1;
        mesh.name = 'wifi-map';
        studio.scene3d.add(mesh);
        M.overlay = mesh;
        M.overlayShown = (M.overlayShown || 0) + 1;
        mesh.visible = overlayBox.checked;
        mapText.textContent = rep.min.toFixed(0) + '..' + rep.max.toFixed(0) + ' dBm (' +
          rep.access_points.length + ' AP)';
      });
    });
  }
  overlayBox.onchange = () => showOverlay(overlayBox.checked);
  apSel.onchange = () => { if (overlayBox.checked) showOverlay(true); };
  M.showOverlay = (on) => { overlayBox.checked = on; showOverlay(on); };

  function askInfo() {
    ask({op: 'world_info'}).then((rep) => {
      if (rep.ok) addIcons(rep); else say(rep);
    });
  }
  // once the page has its scene (this script may load after the first hello), and again
  // after a reconnect
  (function wait() { if (studio.ready) askInfo(); else setTimeout(wait, 200); })();
  studio.on('hello', () => { if (studio.ready) askInfo(); });

  // -- the device's switches, environment, faults and outputs ---------------------------------
  const dev = studio.panel('device controls', 'device-controls');
  dev.className = 'devctl';
  const battery = el('span', {testid: 'battery-level'}, '-');
  const charger = el('input', {type: 'checkbox', testid: 'charger'});
  charger.onchange = () => studio.send({op: 'charger', model: phone(), plugged: charger.checked}).then(say);
  const b1 = el('div', {class: 'row'});
  b1.append('battery ', battery, ' ', lbl(charger, 'charger'));
  const radios = el('div', {class: 'row'});
  for (const r of ['wifi', 'bluetooth', 'cellular', 'nfc']) {
    const box = el('input', {type: 'checkbox', testid: 'radio-' + r, checked: '',
                             title: r + ' on or off (' + r + '/enable)'});
    box.onchange = () => studio.send({op: 'radio', model: phone(), radio: r,
                                      enabled: box.checked}).then(say);
    radios.append(lbl(box, r), ' ');
  }
  const buttons = el('div', {class: 'row'});
  for (const b of ['power', 'volume_up', 'volume_down']) {
    const btn = el('button', {testid: 'button-' + b}, b.replace('_', ' '));
    btn.onclick = () => studio.send({op: 'press_button', model: phone(), button: b}).then(say);
    buttons.append(btn);
  }
  // the environment (names of /gazebo/set_environment): the time of day (local solar
  // hours: the world's daylight then follows the sun) or the daylight's lux, whichever was
  // filled in last (the other is emptied), the temperature, the magnetic declination
  const env = el('form', {testid: 'environment'});
  const DAY = [['', 'time of day'], ['0', 'midnight (0:00)'], ['6', 'sunrise (6:00)'],
               ['9', 'morning (9:00)'], ['12', 'noon (12:00)'], ['18', 'sunset (18:00)'],
               ['21', 'night (21:00)']];
  const day = el('select', {name: 'time_preset', testid: 'time-of-day'});
  for (const [k, text] of DAY) day.append(el('option', {value: k}, text));
  const num = (name, title, w) => el('input', {type: 'number', step: 'any', name: name,
                                               title: title, placeholder: title,
                                               testid: 'env-' + name, style: 'width:' + w});
  const hours = num('time_of_day', 'time of day h', '5em');
  hours.min = '0'; hours.max = '24';
  const temp = num('temperature', 'temperature degC', '5em');
  const light = num('daylight', 'daylight lux', '6em');
  const decl = num('magnetic_declination', 'declination deg', '6em');
  day.onchange = () => { if (day.value !== '') { hours.value = day.value; light.value = ''; } };
  hours.addEventListener('input', () => { if (hours.value !== '') light.value = ''; });
  light.addEventListener('input', () => {
    if (light.value !== '') { hours.value = ''; day.value = ''; }
  });
  const setEnv = el('button', {type: 'submit', testid: 'env-set'}, 'set');
  env.append(day, ' ', hours, ' ', temp, ' ', light, ' ', decl, ' ', setEnv);
  env.onsubmit = (e) => {
    e.preventDefault();
    const values = {};
    for (const i of [hours, temp, light, decl]) {
      if (i.value !== '') values[i.name] = parseFloat(i.value);
    }
    studio.send({op: 'set_environment', values: values}).then(say);
  };
  // outputs
  const outs = el('div', {class: 'row outputs'});
  const led = el('span', {class: 'led', testid: 'out-led', title: 'LED (led/state)'});
  const vib = el('span', {testid: 'out-vibration', title: 'the motor now (vibration/state)'}, '-');
  const spk = el('span', {testid: 'out-speaker'}, '-');
  const proj = el('span', {testid: 'out-projector'}, '-');
  outs.append('LED ', led, ' vibration ', vib, ' speaker ', spk, ' projector ', proj);
  const faults = el('div', {class: 'faults', testid: 'faults'});
  dev.append(b1, radios, buttons, env, outs,
             el('div', {class: 'hint'}, 'a fault per sensor (set_sensor_fault)'), faults);

  const FAULTS = ['none', 'drop', 'freeze', 'noise'];
  const fields = (v) => (v ? Object.fromEntries(v.fields) : null);
  studio.on('device', (m) => {
    const ns = '/' + phone() + '/';
    const bat = fields(m.topics[ns + 'battery_state']);
    if (bat) battery.textContent = (bat.percentage * 100).toFixed(1) + ' %' +
      (bat.power_supply_status === 1 ? ' (charging)' : '');
    const ls = fields(m.topics[ns + 'led/state']);
    if (ls) {
      led.style.background = ls.a ? 'rgb(' + [ls.r, ls.g, ls.b].map((x) => Math.round(x * 255)) + ')' : '#222';
      led.dataset.rgba = [ls.r, ls.g, ls.b, ls.a].join(',');
    }
    // whether the motor runs now (the plugin's vibration/state: the amplitude now), not
    // the last command
    const vb = fields(m.topics[ns + 'vibration/state']);
    if (vb) {
      vib.textContent = vb.data > 0 ? 'running (amplitude ' + (+vb.data).toFixed(2) + ')' : 'off';
      vib.dataset.amplitude = vb.data;
    }
    const pj = fields(m.topics[ns + 'projector/enable']);
    if (pj) proj.textContent = pj.data ? 'on' : 'off';
    for (const topic of Object.keys(m.topics).sort()) {
      if (!topic.startsWith(ns) || faults.querySelector('select[data-topic="' + topic + '"]')) continue;
      const s = el('select', {testid: 'fault-select', 'data-topic': topic});
      for (const f of FAULTS.concat(m.topics[topic].type === 'sensor_msgs/NavSatFix' ? ['no_fix'] : [])) {
        s.append(el('option', {value: f}, f));
      }
      s.onchange = () => studio.send({op: 'fault', model: phone(), sensor: topic,
                                      fault: s.value}).then(say);
      const r = el('div', {class: 'row'});
      r.append(s, ' ' + topic.slice(ns.length));
      faults.append(r);
    }
  });
  studio.on('outputs', (m) => {
    const v = m.speaker[phone()];
    spk.textContent = v === null || v === undefined ? 'silent' : v.toFixed(1) + ' dBFS';
  });
})();
