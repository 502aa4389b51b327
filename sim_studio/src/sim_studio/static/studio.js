// The studio's page: one WebSocket (/ws) carrying the versioned JSON protocol (v 1).
'use strict';
(function () {
  const $ = (id) => document.getElementById(id);
  const token = new URLSearchParams(location.search).get('token');
  const wsUrl = (location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/ws' +
    (token ? '?token=' + encodeURIComponent(token) : '');
  const studio = window.studio = {
    frames: 0, firstFrameAt: null, poses: {}, models: {}, selected: 'mobile_device',
    dragging: false, replies: {}, cameraFrames: 0, ready: false, displays: {},
    device: {}, hist: {}, deviceMessages: 0, links: {}, cameras: {}, view: 'free',
    displayImages: {}, displayFrames: 0,
  };
  let ws = null, nextId = 1;
  const pending = {};

  function send(cmd) {
    cmd.v = 1;
    cmd.id = nextId++;
    return new Promise((resolve) => {
      pending[cmd.id] = resolve;
      ws.send(JSON.stringify(cmd));
    });
  }
  studio.send = send;

  // -- 3D view ---------------------------------------------------------------------------
  const canvas = $('viewport');
  const renderer = new THREE.WebGLRenderer({canvas: canvas, antialias: true,
                                            preserveDrawingBuffer: true});
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xb0b8c0);
  THREE.Object3D.DefaultUp.set(0, 0, 1);
  const camera = new THREE.PerspectiveCamera(50, 1, 0.01, 200);
  camera.up.set(0, 0, 1);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x555555, 0.9));
  const sun = new THREE.DirectionalLight(0xffffff, 0.6);
  sun.position.set(3, -2, 6);
  scene.add(sun);
  const orbit = new THREE.OrbitControls(camera, canvas);
  const handle = new THREE.TransformControls(camera, canvas);
  handle.setSpace('world');
  scene.add(handle);
  studio.handle = handle;
  studio.camera = camera;
  // the page's API for the extensions (static/ext/*.js, sim_studio/extensions.py)
  studio.scene3d = scene;
  studio.renderer = renderer;
  studio.orbit = orbit;
  studio.live = true;           // false: the stream's poses are not shown (an extension
                                // shows poses of its own, e.g. a recording's)
  const listeners = {}, frameHooks = [];
  // fn(message) for each stream message or reply of that type ('poses', 'hello', 'device',
  // 'recording', 'control', 'reply', an extension's own stream type; 'camera': the image URL)
  studio.on = (type, fn) => { (listeners[type] = listeners[type] || []).push(fn); };
  const emit = (type, m) => { for (const fn of listeners[type] || []) fn(m); };
  studio.onFrame = (fn) => { frameHooks.push(fn); };     // fn(now) before each render
  // a panel of the right-hand column: its heading and an empty element (returned)
  studio.panel = (title, testid) => {
    const h = document.createElement('h3'), d = document.createElement('div');
    h.textContent = title;
    if (testid) d.dataset.testid = testid;
    $('ext').append(h, d);
    return d;
  };

  function resize() {
    const w = canvas.clientWidth, h = canvas.clientHeight;
    if (canvas.width !== w || canvas.height !== h) {
      renderer.setSize(w, h, false);
      camera.aspect = w / Math.max(1, h);
      camera.updateProjectionMatrix();
    }
  }

  function geometry(g) {
    if (g.kind === 'box') return new THREE.BoxBufferGeometry(g.size[0], g.size[1], g.size[2]);
    if (g.kind === 'sphere') return new THREE.SphereBufferGeometry(g.radius, 24, 16);
    if (g.kind === 'cylinder') {
      const c = new THREE.CylinderBufferGeometry(g.radius, g.radius, g.length, 24);
      c.rotateX(Math.PI / 2);           // three's cylinders stand on y, ROS's on z
      return c;
    }
    if (g.kind === 'plane') return new THREE.PlaneBufferGeometry(g.size[0], g.size[1]);
    return new THREE.BoxBufferGeometry(0.05, 0.05, 0.05);
  }

  // a mesh (or a textured shape): its bounding box until the renderer's own triangles
  // arrive from the studio (/shape/N: a JSON header, then positions, normals, uvs)
  studio.shapes = [];
  studio.shapeBoxes = false;
  function shapeVisual(g, mat) {
    const grp = new THREE.Group();
    const box = new THREE.Mesh(new THREE.BoxBufferGeometry(
      Math.max(g.size[0], 1e-3), Math.max(g.size[1], 1e-3), Math.max(g.size[2], 1e-3)), mat);
    box.position.set(g.center[0], g.center[1], g.center[2]);
    grp.add(box);
    const rec = {url: g.url, box: box, mesh: null};
    studio.shapes.push(rec);
    fetch(g.url).then((r) => {
      if (!r.ok) throw new Error('HTTP ' + r.status);
      return r.arrayBuffer();
    }).then((buf) => {
      const n = new DataView(buf).getUint32(0, true);
      const head = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 4, n)));
      const c = head.count;
      let off = 4 + n;
      const geo = new THREE.BufferGeometry();
      geo.setAttribute('position', new THREE.BufferAttribute(new Float32Array(buf, off, 3 * c), 3));
      off += 12 * c;
      geo.setAttribute('normal', new THREE.BufferAttribute(new Float32Array(buf, off, 3 * c), 3));
      off += 12 * c;
      geo.setAttribute('uv', new THREE.BufferAttribute(new Float32Array(buf, off, 2 * c), 2));
      const mats = head.parts.map((p, i) => {
        geo.addGroup(p.first, p.count, i);
        const m = new THREE.MeshLambertMaterial({
          color: new THREE.Color(p.rgba[0], p.rgba[1], p.rgba[2]), transparent: p.rgba[3] < 1,
          opacity: p.rgba[3], side: head.double ? THREE.DoubleSide : THREE.FrontSide});
        if (p.texture) {
          m.map = new THREE.TextureLoader().load(p.texture);
          m.map.flipY = false;             // t = 0 is the image's top row, as the renderer has it
        }
        return m;
      });
      rec.mesh = new THREE.Mesh(geo, mats);
      grp.add(rec.mesh);
      showShapeBoxes(studio.shapeBoxes);
      studio.shapesLoaded = (studio.shapesLoaded || 0) + 1;
    }).catch((e) => { $('status').textContent = 'cannot load ' + g.url + ': ' + e; });
    return grp;
  }
  // draw the shapes' bounding boxes instead of their triangles (true) or not
  function showShapeBoxes(on) {
    studio.shapeBoxes = on;
    for (const r of studio.shapes) {
      if (!r.mesh) continue;
      r.mesh.visible = !on;
      r.box.visible = on;
    }
  }
  studio.showShapeBoxes = showShapeBoxes;
  // look at a model from (dx, dy, dz) away
  studio.lookAt = function (name, d) {
    const obj = studio.models[name];
    if (!obj) return false;
    const p = obj.getWorldPosition(new THREE.Vector3());
    d = d || [0, -0.9, 0.6];
    orbit.target.copy(p);
    camera.position.set(p.x + d[0], p.y + d[1], p.z + d[2]);
    orbit.update();
    return true;
  };
  // where a model's origin (or a link's) is on the screen
  studio.screenPoint = function (name, link) {
    let obj = studio.models[name];
    if (obj && link) obj = obj.getObjectByName(link) || obj;
    const p = obj.getWorldPosition(new THREE.Vector3()).project(camera);
    const rect = canvas.getBoundingClientRect();
    return {x: rect.left + (p.x + 1) / 2 * rect.width, y: rect.top + (1 - p.y) / 2 * rect.height};
  };

  function setPose(obj, p) {
    obj.position.set(p.position[0], p.position[1], p.position[2]);
    obj.quaternion.set(p.orientation[0], p.orientation[1], p.orientation[2], p.orientation[3]);
  }

  function build(sceneDesc) {
    for (const m of sceneDesc.models) {
      if (m.display && !studio.displays[m.name]) studio.displays[m.name] = m.display;
      if (m.cameras && !studio.cameras[m.name]) studio.cameras[m.name] = m.cameras;
      if (studio.models[m.name]) continue;
      const root = new THREE.Group();
      root.name = m.name;
      let drawn = 0;
      for (const ln of m.links) {
        const lg = new THREE.Group();
        lg.name = ln.name;
        setPose(lg, ln.pose);
        for (const v of ln.visuals) {
          const mat = new THREE.MeshLambertMaterial({
            color: new THREE.Color(v.rgba[0], v.rgba[1], v.rgba[2]),
            transparent: v.rgba[3] < 1, opacity: v.rgba[3], side: THREE.DoubleSide});
          const mesh = v.geometry.kind === 'shape' ? shapeVisual(v.geometry, mat) :
            new THREE.Mesh(geometry(v.geometry), mat);
          setPose(mesh, v.origin);
          lg.add(mesh);
          drawn++;
        }
        root.add(lg);
      }
      if (!drawn) {             // a model the studio has no description of: a small box
        root.add(new THREE.Mesh(new THREE.BoxBufferGeometry(0.1, 0.1, 0.1),
                                new THREE.MeshLambertMaterial({color: 0xff00ff})));
      }
      setPose(root, m.pose);
      scene.add(root);
      studio.models[m.name] = root;
      const o = document.createElement('option');
      o.value = o.textContent = m.name;
      $('model').appendChild(o);
    }
    $('model').value = studio.selected;
    select(studio.selected);
    drawDisplay();
  }

  // -- the phone's display: what it shows, and a click on it is a touch -------------------
  function phone() {
    if (studio.displays[studio.selected]) return studio.selected;
    return Object.keys(studio.displays)[0];
  }
  function drawDisplay() {
    const name = phone(), d = studio.displays[name], c = $('display');
    if (!d) return;
    const w = 150, h = Math.round(w * d.height / d.width);
    if (c.width !== w || c.height !== h) { c.width = w; c.height = h; }
    const g = c.getContext('2d');
    const img = studio.displayImages[name];  // the latest of its own image topic (stream)
    g.fillStyle = '#0000ff';                // textvid's display before its first image
    g.fillRect(0, 0, w, h);
    if (img && img.naturalWidth) g.drawImage(img, 0, 0, w, h);     // scaled to the display
    const t = studio.device['/' + name + '/touch'];
    if (t && studio.simTime - t.stamp < 1.0) {     // the last touch event, for a second
      const f = Object.fromEntries(t.fields);
      g.strokeStyle = f.action === 1 ? '#ff0' : '#f00';
      g.lineWidth = 2;
      g.beginPath();
      g.arc(f.x / d.width * w, f.y / d.height * h, 6, 0, 2 * Math.PI);
      g.stroke();
    }
  }
  $('display').addEventListener('click', (e) => {
    const name = phone(), r = $('display').getBoundingClientRect();
    if (!name) return;
    const x = Math.min(1, Math.max(0, (e.clientX - r.left) / r.width));
    const y = Math.min(1, Math.max(0, (e.clientY - r.top) / r.height));
    studio.lastTouch = {model: name, x: x, y: y};
    send({op: 'touch', model: name, x: x, y: y}).then(showError);
  });

  // -- assert mode: a click on a device value becomes an expectation of the scenario -------
  studio.asserting = false;
  $('assert').onclick = () => {
    studio.asserting = !studio.asserting;
    $('assert').classList.toggle('on', studio.asserting);
    document.body.classList.toggle('asserting', studio.asserting);
    if (!studio.asserting) $('assertform').hidden = true;
  };
  $('device').addEventListener('click', (e) => {
    const cell = e.target.closest('td.v');
    if (!studio.asserting || !cell) return;
    const v = parseFloat(cell.textContent);
    const f = $('assertform');
    f.dataset.topic = cell.dataset.topic;
    f.dataset.field = cell.dataset.field;
    $('a-what').textContent = cell.dataset.topic + ' ' + cell.dataset.field;
    f.elements.a.value = isFinite(v) ? v : '';
    f.elements.b.value = isFinite(v) ? parseFloat((Math.abs(v) * 0.1 || 0.1).toPrecision(3)) : '';
    f.hidden = false;
  });
  $('a-cancel').onclick = () => { $('assertform').hidden = true; };
  $('assertform').onsubmit = (e) => {
    e.preventDefault();
    const f = e.target, el = f.elements, a = parseFloat(el.a.value), b = parseFloat(el.b.value);
    const cmd = {op: 'expect', topic: f.dataset.topic, field: f.dataset.field,
                 mode: el.mode.value, check: el.check.value, target: a};
    if (el.check.value === 'near') cmd.tol = b;
    if (el.check.value === 'between') { cmd.target = undefined; cmd.lo = a; cmd.hi = b; }
    send(JSON.parse(JSON.stringify(cmd))).then((rep) => {
      showError(rep);
      if (rep.ok) {
        $('yaml').value = rep.yaml;
        f.hidden = true;
      }
    });
  };

  // -- the device panel: each topic's latest values and a plot over sim time ------------------
  const COLORS = ['#f66', '#6d6', '#69f', '#fc4'];
  function fmt(v) {
    if (typeof v !== 'number') return String(v);
    if (v !== 0 && (Math.abs(v) >= 1e7 || Math.abs(v) < 1e-4)) return v.toExponential(6);
    return String(parseFloat(v.toPrecision(7)));
  }
  function showDevice(m) {
    studio.deviceMessages++;
    studio.device = m.topics;
    const panel = $('device');
    for (const topic of Object.keys(m.topics).sort()) {
      const v = m.topics[topic];
      let box = panel.querySelector('.topic[data-topic="' + topic + '"]');
      if (!box) {
        box = document.createElement('div');
        box.className = 'topic';
        box.dataset.topic = topic;
        box.innerHTML = '<div class="title"></div><canvas data-testid="plot" width="320" ' +
          'height="48"></canvas><table></table>';
        box.querySelector('.title').textContent = topic + '  (' + v.type + ')';
        box.querySelector('canvas').dataset.topic = topic;
        panel.appendChild(box);
      }
      const table = box.querySelector('table');
      for (const [path, val] of v.fields) {
        let row = table.querySelector('tr[data-field="' + path + '"]');
        if (!row) {
          row = document.createElement('tr');
          row.dataset.field = path;
          row.innerHTML = '<td></td><td class="v" data-testid="device-value"></td>';
          row.firstChild.textContent = path;
          row.lastChild.dataset.topic = topic;
          row.lastChild.dataset.field = path;
          table.appendChild(row);
        }
        row.lastChild.textContent = fmt(val);
      }
      const t = v.stamp !== null && v.stamp !== undefined ? v.stamp : m.t;
      const nums = v.fields.filter((f) => typeof f[1] === 'number').slice(0, 4);
      let h = studio.hist[topic];
      if (!h || (h.length && t < h[h.length - 1].t)) h = studio.hist[topic] = [];
      if (!h.length || t > h[h.length - 1].t) h.push({t: t, v: nums.map((f) => f[1])});
      while (h.length && h[0].t < t - 30) h.shift();
      plot(box.querySelector('canvas'), h, nums.map((f) => f[0]));
    }
  }
  function plot(c, h, names) {
    const g = c.getContext('2d'), w = c.width, ht = c.height;
    g.fillStyle = '#15181c';
    g.fillRect(0, 0, w, ht);
    if (h.length < 2) return;
    const t0 = h[0].t, t1 = Math.max(h[h.length - 1].t, t0 + 1e-9);
    names.forEach((_n, k) => {
      let lo = Infinity, hi = -Infinity;
      for (const p of h) { if (p.v[k] < lo) lo = p.v[k]; if (p.v[k] > hi) hi = p.v[k]; }
      const span = hi - lo || 1;
      g.strokeStyle = COLORS[k];
      g.beginPath();
      h.forEach((p, i) => {
        const x = (p.t - t0) / (t1 - t0) * (w - 2) + 1;
        const y = ht - 3 - (p.v[k] - lo) / span * (ht - 6);
        if (i) g.lineTo(x, y); else g.moveTo(x, y);
      });
      g.stroke();
    });
  }

  function select(name) {
    studio.selected = name;
    const obj = studio.models[name];
    if (obj) {
      handle.attach(obj);
      fillForm(name);
    }
  }
  $('model').addEventListener('change', (e) => select(e.target.value));

  function rpyOf(obj) {
    const e = new THREE.Euler().setFromQuaternion(obj.quaternion, 'ZYX');
    return [e.x, e.y, e.z];
  }

  function fillForm(name) {
    const obj = studio.models[name];
    if (!obj) return;
    const f = $('poseform').elements, r = rpyOf(obj);
    const vals = {x: obj.position.x, y: obj.position.y, z: obj.position.z,
                  roll: r[0], pitch: r[1], yaw: r[2]};
    for (const k in vals) {
      if (document.activeElement !== f[k]) f[k].value = vals[k].toFixed(3);
    }
  }

  // the handle: set_pose while dragging (at most every 50 ms) and once at its end
  let lastSent = 0;
  function sendHandlePose() {
    const obj = handle.object;
    if (!obj) return;
    lastSent = performance.now();
    send({op: 'set_pose', model: obj.name,
          position: [obj.position.x, obj.position.y, obj.position.z], rpy: rpyOf(obj)})
      .then(showError);
  }
  handle.addEventListener('dragging-changed', (e) => {
    orbit.enabled = !e.value;
    studio.dragging = e.value;
    if (!e.value) sendHandlePose();
  });
  handle.addEventListener('objectChange', () => {
    if (studio.dragging && performance.now() - lastSent > 50) sendHandlePose();
  });
  window.addEventListener('keydown', (e) => {
    if (e.target.tagName === 'INPUT' || e.target.tagName === 'TEXTAREA') return;
    if (e.key === 'r') handle.setMode('rotate');
    if (e.key === 't') handle.setMode('translate');
  });

  // where the handle's arrow for an axis is on the screen (the browser test drags it)
  studio.handlePoint = function (axis) {
    const obj = handle.object;
    const pos = obj.getWorldPosition(new THREE.Vector3());
    const dist = pos.distanceTo(camera.position);
    const f = dist * Math.min(1.9 * Math.tan(Math.PI * camera.fov / 360) / camera.zoom, 7) *
      handle.size / 7;
    const d = {X: [1, 0, 0], Y: [0, 1, 0], Z: [0, 0, 1]}[axis];
    const p = pos.clone().add(new THREE.Vector3(d[0], d[1], d[2]).multiplyScalar(0.6 * f));
    p.project(camera);
    const rect = canvas.getBoundingClientRect();
    return {x: rect.left + (p.x + 1) / 2 * rect.width,
            y: rect.top + (1 - p.y) / 2 * rect.height};
  };

  // -- view modes: free (orbit), follow the selected model, through the phone's camera ------
  // a Gazebo camera looks along its link's +x with +z up; a three.js camera along -z, +y up
  const CAM_FIX = new THREE.Matrix4().makeBasis(new THREE.Vector3(0, -1, 0),
    new THREE.Vector3(0, 0, 1), new THREE.Vector3(-1, 0, 0));
  function phoneCamera() {
    const name = studio.cameras[studio.selected] ? studio.selected :
      Object.keys(studio.cameras)[0];
    const c = name && studio.cameras[name][0];
    const obj = c && studio.models[name] && studio.models[name].getObjectByName(c.link);
    return obj ? {obj: obj, desc: c} : null;
  }
  function setView(mode) {
    studio.view = mode;
    $('view').value = mode;
    studio.followAt = null;
    orbit.enabled = mode !== 'camera';
    if (mode !== 'camera' && camera.fov !== 50) {
      camera.fov = 50;
      camera.updateProjectionMatrix();
      studio.lookAt(studio.selected);
    }
  }
  studio.setView = setView;
  $('view').addEventListener('change', (e) => setView(e.target.value));
  function applyView() {
    const obj = studio.models[studio.selected];
    if (studio.view === 'follow' && obj) {
      const p = obj.getWorldPosition(new THREE.Vector3());
      if (studio.followAt) {
        const d = p.clone().sub(studio.followAt);
        camera.position.add(d);
        orbit.target.add(d);
      }
      studio.followAt = p;
    } else if (studio.view === 'camera') {
      const c = phoneCamera();
      if (!c) return;
      c.obj.updateMatrixWorld(true);
      m4.multiplyMatrices(c.obj.matrixWorld, CAM_FIX);
      m4.decompose(camera.position, camera.quaternion, v3);
      const fov = 2 * Math.atan(Math.tan(c.desc.hfov / 2) * c.desc.height / c.desc.width);
      if (Math.abs(camera.fov - fov * 180 / Math.PI) > 1e-6) {
        camera.fov = fov * 180 / Math.PI;       // the sensor's vertical field of view
        camera.updateProjectionMatrix();
      }
    }
  }

  const inv = new THREE.Matrix4(), m4 = new THREE.Matrix4(), v3 = new THREE.Vector3();
  const q4 = new THREE.Quaternion(), one = new THREE.Vector3(1, 1, 1);
  function frame() {
    resize();
    for (const name in studio.poses) {
      const obj = studio.models[name];
      if (!obj || (studio.dragging && handle.object === obj)) continue;
      const p = studio.poses[name];
      obj.position.set(p[0], p[1], p[2]);
      obj.quaternion.set(p[3], p[4], p[5], p[6]);
      const links = studio.links[name];
      if (links) {                 // jointed: each link where /gazebo/link_states has it
        obj.updateMatrixWorld();
        inv.getInverse(obj.matrixWorld);
        for (const ln of obj.children) {
          const q = links[ln.name];
          if (!q) continue;
          m4.compose(v3.set(q[0], q[1], q[2]), q4.set(q[3], q[4], q[5], q[6]), one);
          m4.premultiply(inv);
          m4.decompose(ln.position, ln.quaternion, ln.scale);
        }
      }
    }
    for (const fn of frameHooks) fn(performance.now());
    applyView();
    if (studio.view !== 'camera') orbit.update();
    renderer.render(scene, camera);
    if (studio.ready) {
      studio.frames++;
      if (studio.firstFrameAt === null) studio.firstFrameAt = performance.now();
    }
    if (studio.frames % 10 === 1) { fillForm(studio.selected); drawDisplay(); }
    requestAnimationFrame(frame);
  }

  // -- the stream and the replies ---------------------------------------------------------
  function showError(rep) {
    $('status').textContent = rep && !rep.ok ? rep.error : '';
    return rep;
  }

  let cameraUrl = null;
  function connect() {
    ws = new WebSocket(wsUrl);
    ws.binaryType = 'blob';
    ws.onmessage = (ev) => {
      ev.target.send('ack');      // flow control: the server sends on as the page takes in
      if (typeof ev.data !== 'string') {
        const url = URL.createObjectURL(ev.data);
        $('camera').src = url;
        if (cameraUrl) URL.revokeObjectURL(cameraUrl);
        cameraUrl = url;
        studio.cameraFrames++;
        emit('camera', url);
        return;
      }
      const m = JSON.parse(ev.data);
      if (m.type === 'reply') {
        const r = pending[m.id];
        delete pending[m.id];
        if (r) r(m); else showError(m);
      } else if (m.type === 'poses') {
        if (studio.live) {
          studio.poses = m.poses;
          studio.links = m.links || {};
        }
        if (studio.ready && !studio.asking &&
            Object.keys(m.poses).some((n) => !studio.models[n])) {
          studio.asking = true;          // a model spawned since: its description
          send({op: 'scene'}).then((rep) => { build(rep.scene); studio.asking = false; });
        }
        studio.simTime = m.t;
        $('simtime').textContent = m.t.toFixed(3);
        $('rtf').textContent = m.rtf.toFixed(2);
        const banner = $('banner');
        banner.hidden = !m.world_gone;
        if (m.world_gone) {
          banner.textContent = m.world_gone.error + '\n' + m.world_gone.log.join('\n');
        }
      } else if (m.type === 'hello') {
        studio.name = m.name;
        studio.cameraTopic = m.camera_topic;
        showRecording(m.recording, m.yaml);
        // the scene first: a client's commands are answered in turn, and the device
        // panel's (subscribing to every phone topic) must not hold back the first frame
        send({op: 'scene'}).then((rep) => {
          const s = rep.scene;
          if (studio.ready) { build(s); return; }      // a reconnect
          const phone = s.models.find((x) => x.name === studio.selected) || s.models[0];
          if (phone) {
            studio.selected = phone.name;
            const p = phone.pose.position;
            orbit.target.set(p[0], p[1], p[2]);
            camera.position.set(p[0], p[1] - 0.9, p[2] + 0.6);
          }
          build(s);
          studio.ready = true;
        });
        send({op: 'device', on: true});
      } else if (m.type === 'display') {
        // a phone display's image topic (its own stream): shown once decoded, so the
        // canvas never draws an image that is still loading
        const img = new Image();
        img.onload = () => {
          studio.displayImages[m.model] = img;
          studio.displayFrames++;
          drawDisplay();
        };
        img.src = 'data:image/jpeg;base64,' + m.jpeg;
      } else if (m.type === 'device') {
        showDevice(m);
      } else if (m.type === 'recording') {
        showRecording(m.on, m.yaml);
      } else if (m.type === 'control') {
        $('control').textContent = m.you ? 'you have control' :
          (m.holder ? 'read-only (' + m.holder + ' has control)' : '');
      }
      emit(m.type, m);
    };
    ws.onclose = () => {
      $('status').textContent = 'disconnected from the studio; reconnecting';
      setTimeout(connect, 1000);
    };
  }

  function showRecording(on, yaml) {
    studio.recording = on;
    $('record').classList.toggle('on', on);
    $('record').textContent = on ? 'stop recording' : 'record';
    if (yaml !== undefined && (on || studio.recordedOnce)) $('yaml').value = yaml;
  }

  // -- controls -----------------------------------------------------------------------------
  $('play').onclick = () => send({op: 'play'}).then(showError);
  $('pause').onclick = () => send({op: 'pause'}).then(showError);
  $('reset').onclick = () => send({op: 'reset'}).then(showError);
  $('step').onclick = () => send({op: 'step', until: parseFloat($('until').value)})
    .then(showError);
  $('record').onclick = () => {
    studio.recordedOnce = true;
    send({op: 'record', on: !studio.recording}).then((rep) => {
      showError(rep);
      if (rep.ok) showRecording(rep.recording, rep.yaml);
    });
  };
  $('poseform').onsubmit = (e) => {
    e.preventDefault();
    const f = e.target.elements, n = (k) => parseFloat(f[k].value);
    send({op: 'set_pose', model: $('model').value, position: [n('x'), n('y'), n('z')],
          rpy: [n('roll'), n('pitch'), n('yaw')]}).then(showError);
  };
  let checkTimer = null;
  $('yaml').addEventListener('input', () => {
    clearTimeout(checkTimer);
    checkTimer = setTimeout(() => send({op: 'check', yaml: $('yaml').value}).then((rep) => {
      $('problems').textContent = rep.ok ? rep.problems.join('\n') : rep.error;
    }), 300);
  });
  $('run').onclick = () => {
    $('verdicts').textContent = 'running...';
    $('run').disabled = true;
    send({op: 'run', yaml: $('yaml').value}).then((rep) => {
      $('run').disabled = false;
      const v = $('verdicts');
      v.textContent = '';
      if (!rep.ok) { v.textContent = 'ERROR ' + rep.error; return; }
      for (const p of rep.problems || []) v.appendChild(line('ERROR', p));
      for (const x of rep.verdicts) v.appendChild(line(x.status, x.line));
      v.appendChild(line(rep.status, 'scenario: ' + rep.status));
    });
  };
  function line(cls, text) {
    const d = document.createElement('div');
    d.className = cls;
    d.textContent = text;
    return d;
  }

  studio.select = select;
  studio.build = build;
  studio.showError = showError;
  studio.line = line;
  connect();
  requestAnimationFrame(frame);
})();
